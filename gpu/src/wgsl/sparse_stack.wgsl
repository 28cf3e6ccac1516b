// STACK over the sparse layout's own-box nodes (structures/sparse/stack.rs):
// the same algorithm as bvh_stack.wgsl over the nodes the stackless
// traversals use, for ratios on the same nodes.

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let id = ray_id(gid);
    if id >= params.count {
        return;
    }
    if start(id) {
        var stack: array<u32, STACK_SIZE>;
        var top = 0u;
        var node = 0u;
        loop {
            let s = walk_step(node);
            if s == STEP_DONE {
                break;
            }
            if s == STEP_INNER {
                let left = step_left;
                if step_kids == KIDS_BOTH_LEFT_FIRST || step_kids == KIDS_BOTH_RIGHT_FIRST {
                    let right_first = step_kids == KIDS_BOTH_RIGHT_FIRST;
                    node = select(left, left + 1u, right_first);
                    stack[top] = select(left + 1u, left, right_first);
                    top += 1u;
                    continue;
                }
                if step_kids != KIDS_NONE {
                    node = left + select(0u, 1u, step_kids == KIDS_RIGHT);
                    continue;
                }
            }
            if top == 0u {
                break;
            }
            top -= 1u;
            node = stack[top];
        }
    }
    finish(id);
}
