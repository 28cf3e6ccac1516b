// HAPALA (Hapala et al. 2011; structures/sparse/hapala.rs): stackless over
// parent links, the near child chosen by the direction's sign on the
// node's split axis (a zero component goes right), each child's box tested
// on arrival.

const CAME_PARENT: u32 = 0u;
const CAME_SIBLING: u32 = 1u;
const CAME_CHILD: u32 = 2u;

fn near_child(n: u32) -> u32 {
    let left = sp_link(n) & ~LAST;
    return select(left + 1u, left, ray.d[sp_axis(n)] > 0.0);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let id = ray_id(gid);
    if id >= params.count {
        return;
    }
    if start(id) {
        n_nodes += 1u;
        let root = sp_link(0u);
        if (root & LAST) != 0u {
            leaf(root & ~LAST);
        } else {
            var cur = near_child(0u);
            var came = CAME_PARENT;
            loop {
                if came == CAME_CHILD {
                    if cur == 0u {
                        break;
                    }
                    let p = sp_parent(cur);
                    if cur == near_child(p) {
                        cur = sibling(cur);
                        came = CAME_SIBLING;
                    } else {
                        cur = p;
                    }
                    continue;
                }
                let link = sp_link(cur);
                n_planes += 6u;
                let hit = own_box_test(cur) != inf();
                if hit && (link & LAST) == 0u {
                    n_nodes += 1u;
                    cur = near_child(cur);
                    came = CAME_PARENT;
                    continue;
                }
                if hit {
                    n_nodes += 1u;
                    if leaf(link & ~LAST) {
                        break;
                    }
                }
                if came == CAME_PARENT {
                    cur = sibling(cur);
                    came = CAME_SIBLING;
                } else {
                    cur = sp_parent(cur);
                    came = CAME_CHILD;
                }
            }
        }
    }
    finish(id);
}
