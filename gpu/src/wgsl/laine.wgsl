// LAINE-k (Laine 2010; structures/sparse/laine.rs): a restart trail of one
// bit per level (64 bits, root at bit 63) and a short stack of SHORT_K
// entries (the oldest dropped when full); on an empty short stack the
// traversal restarts at the root and follows the trail. Short stacks below
// 4 entries, as the CPU's kernel: a word `path` (a bit per level, set where
// the current path takes the right child) lets a restart pass through the
// path's nodes above the pop target's parent without testing their boxes
// (a visit each, no plane tests), then test at that parent.

const K: u32 = SHORT_K;

// The short stack and its size.
var<private> short: array<u32, 8>;
var<private> head: u32;

// Pushes `far` onto the short stack (none when K is 0), dropping the
// oldest entry when it is full.
fn push_short(far: u32) {
    if K == 0u {
        return;
    }
    if head < K {
        short[head] = far;
        head += 1u;
    } else {
        for (var i = 1u; i < K; i++) {
            short[i - 1u] = short[i];
        }
        short[(K + 7u) % 8u] = far;
    }
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let id = ray_id(gid);
    if id >= params.count {
        return;
    }
    if start(id) {
        let root_level = vec2u(0u, 0x80000000u);
        var node = 0u;
        var trail = vec2u(0u, 0u);
        var level = root_level;
        var pop_level = vec2u(0u, 0u);
        var path = vec2u(0u, 0u);
        head = 0u;
        loop {
            let s = walk_step(node);
            if s == STEP_DONE {
                break;
            }
            if s == STEP_INNER {
                let left = step_left;
                if step_kids == KIDS_BOTH_LEFT_FIRST || step_kids == KIDS_BOTH_RIGHT_FIRST {
                    let right_first = step_kids == KIDS_BOTH_RIGHT_FIRST;
                    let near = select(left, left + 1u, right_first);
                    let far = select(left + 1u, left, right_first);
                    level = u64_shr1(level);
                    let far_taken = u64_nonzero(trail & level);
                    path = (path & ~level) | select(vec2u(0u), level, right_first != far_taken);
                    if far_taken {
                        node = far;
                    } else {
                        node = near;
                        push_short(far);
                    }
                    continue;
                }
                if step_kids != KIDS_NONE {
                    level = u64_shr1(level);
                    if any(level != pop_level) {
                        trail = trail | level;
                        let right = step_kids == KIDS_RIGHT;
                        path = (path & ~level) | select(vec2u(0u), level, right);
                        node = left + select(0u, 1u, right);
                        continue;
                    }
                    // At the pop level with one child hit: the far child is
                    // culled now; the near one is done.
                }
            }
            // Pop: mark this level finished; the carry runs through the
            // finished levels to the deepest pending one.
            trail = trail & u64_neg(level);
            trail = u64_add(trail, level);
            if (trail.y & 0x80000000u) != 0u {
                break;
            }
            level = trail & u64_neg(trail);
            pop_level = level;
            path = path ^ level;
            if K > 0u && head > 0u {
                head -= 1u;
                node = short[head];
            } else {
                node = 0u;
                level = root_level;
                if K < 4u {
                    // Through the path above the pop target's parent.
                    loop {
                        let below = u64_shr1(level);
                        if all(below == pop_level) {
                            break;
                        }
                        n_nodes += 1u;
                        let left = sp_link(node);
                        let right = u64_nonzero(path & below);
                        level = below;
                        node = left + select(0u, 1u, right);
                        if !u64_nonzero(trail & below) {
                            push_short(left + select(1u, 0u, right));
                        }
                    }
                }
            }
        }
    }
    finish(id);
}
