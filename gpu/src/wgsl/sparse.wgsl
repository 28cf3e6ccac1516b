// SPARSE (Barringer and Akenine-Möller 2013, Algorithm 4;
// structures/sparse/sparse.rs): no stack, a 64-bit level index and the
// parent links. Visits exactly STACK's nodes in STACK's order.

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let id = ray_id(gid);
    if id >= params.count {
        return;
    }
    if start(id) {
        var node = 0u;
        var level = vec2u(0u, 0u);
        loop {
            let s = walk_step(node);
            if s == STEP_DONE {
                break;
            }
            if s == STEP_INNER {
                let left = step_left;
                if step_kids == KIDS_BOTH_LEFT_FIRST || step_kids == KIDS_BOTH_RIGHT_FIRST {
                    level = u64_shl1(level);
                    node = left + select(0u, 1u, step_kids == KIDS_BOTH_RIGHT_FIRST);
                    continue;
                }
                if step_kids != KIDS_NONE {
                    // One child rejected: its slot counts as done.
                    level = u64_add(u64_shl1(level), vec2u(1u, 0u));
                    node = left + select(0u, 1u, step_kids == KIDS_RIGHT);
                    continue;
                }
            }
            level = u64_add(level, vec2u(1u, 0u));
            while (level.x & 1u) == 0u {
                node = sp_parent(node);
                level = u64_shr1(level);
            }
            if node == 0u {
                break;
            }
            node = sibling(node);
        }
    }
    finish(id);
}
