// IMPLICIT-B (Barringer and Akenine-Möller 2013, Algorithm 3 with the
// combined index of §2.2; structures/implicit/traverse.rs): the implicit
// heap layout (heap position p in slot p + 1, children of slot i at 2i and
// 2i + 1; gaps are zero words, uploaded as they are), no stack, two
// integers of state. Visits exactly STACK's nodes in STACK's order.

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let id = ray_id(gid);
    if id >= params.count {
        return;
    }
    if start(id) {
        var index = 1u;
        var level_index = 0u;
        loop {
            let s = walk_step_at(index, true);
            if s == STEP_DONE {
                break;
            }
            if s == STEP_INNER {
                if step_kids == KIDS_BOTH_LEFT_FIRST || step_kids == KIDS_BOTH_RIGHT_FIRST {
                    index = (index << 1u) | select(0u, 1u, step_kids == KIDS_BOTH_RIGHT_FIRST);
                    level_index = level_index << 1u;
                    continue;
                }
                if step_kids != KIDS_NONE {
                    index = (index << 1u) | select(0u, 1u, step_kids == KIDS_RIGHT);
                    level_index = (level_index << 1u) + 1u;
                    continue;
                }
            }
            level_index += 1u;
            let up = countTrailingZeros(level_index);
            index = index >> up;
            level_index = level_index >> up;
            if index <= 1u {
                break;
            }
            index = index ^ 1u;
        }
    }
    finish(id);
}
