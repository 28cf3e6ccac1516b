// STACK over the uncompressed binary BVH (structures/bvh/stack.rs): 13-word
// inner nodes holding both children's boxes per axis as
// [lo_l, lo_r, hi_l, hi_r], then the link word; 1-word leaves. The stack of
// node references lives in private memory (STACK_SIZE entries, the CPU's
// stack_capacity for the tree's depth). Nearer child first, ties left.

const INNER_WORDS: u32 = 13u;
const LEFT_LEAF: u32 = 0x80000000u;
const RIGHT_LEAF: u32 = 0x40000000u;
const OFFSET_MASK: u32 = 0x3fffffffu;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let id = ray_id(gid);
    if id >= params.count {
        return;
    }
    if start(id) {
        var stack: array<u32, STACK_SIZE>;
        var sp = 0u;
        var node = params.root;
        loop {
            n_nodes += 1u;
            if (node & LAST) != 0u {
                if leaf(nodes[node & ~LAST]) {
                    break;
                }
            } else {
                let at = node;
                n_planes += 12u;
                let tl = box_test(
                    vec3f(word_f(at), word_f(at + 4u), word_f(at + 8u)),
                    vec3f(word_f(at + 2u), word_f(at + 6u), word_f(at + 10u)),
                    ray.tmin,
                    tmax,
                );
                let tr = box_test(
                    vec3f(word_f(at + 1u), word_f(at + 5u), word_f(at + 9u)),
                    vec3f(word_f(at + 3u), word_f(at + 7u), word_f(at + 11u)),
                    ray.tmin,
                    tmax,
                );
                let link = nodes[at + 12u];
                let l = link & OFFSET_MASK;
                let left_leaf = (link & LEFT_LEAF) != 0u;
                let left = l | select(0u, LAST, left_leaf);
                let r = l + select(INNER_WORDS, 1u, left_leaf);
                let right = r | select(0u, LAST, (link & RIGHT_LEAF) != 0u);
                let hit_l = tl != inf();
                let hit_r = tr != inf();
                if hit_l && hit_r {
                    let right_first = tr < tl;
                    node = select(left, right, right_first);
                    stack[sp] = select(right, left, right_first);
                    sp += 1u;
                    continue;
                }
                if hit_l || hit_r {
                    node = select(left, right, hit_r);
                    continue;
                }
            }
            if sp == 0u {
                break;
            }
            sp -= 1u;
            node = stack[sp];
        }
    }
    finish(id);
}
