// bvh4 and bvh8 (structures/wide/traverse.rs): nodes of WIDTH children,
// NODE_WORDS words each (WideNode: six plane rows of WIDTH floats, min x,
// min y, min z, max x, max y, max z, then WIDTH child references, then
// padding to 64 bytes), leaves as triangle blocks (block_leaf). A
// reference is a node index, or with bit 31 set a leaf's first block;
// lanes after a node's last child are 0xffffffff. No scene-box test: the
// root's children are tested at its first visit. Hit children are visited
// nearest first (a stable sort by entry distance; an any-hit trace takes
// them in lane order), the stack holds references with their entry
// distances, and popped entries beyond the closest hit are skipped.

const WIDE_LEAF: u32 = 0x80000000u;

var<private> stack_ref: array<u32, STACK_SIZE>;
var<private> stack_t: array<f32, STACK_SIZE>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let id = ray_id(gid);
    if id >= params.count {
        return;
    }
    load(id);
    // A negative or NaN tmin misses, as the CPU kernel (wide/traverse.rs).
    if params.empty == 0u && ray.tmin >= 0.0 {
        var sp = 0u;
        var node = params.root;
        loop {
            n_nodes += 1u;
            if (node & WIDE_LEAF) != 0u {
                if block_leaf(node & ~WIDE_LEAF) {
                    break;
                }
            } else {
                // The children the ray enters, in lane order.
                let at = node * NODE_WORDS;
                var e_ref: array<u32, WIDTH>;
                var e_t: array<f32, WIDTH>;
                var m = 0u;
                for (var k = 0u; k < WIDTH; k++) {
                    let child = nodes[at + 6u * WIDTH + k];
                    if child == NONE {
                        break;
                    }
                    n_planes += 6u;
                    let t = box_test(
                        vec3f(word_f(at + k), word_f(at + WIDTH + k), word_f(at + 2u * WIDTH + k)),
                        vec3f(word_f(at + 3u * WIDTH + k), word_f(at + 4u * WIDTH + k), word_f(at + 5u * WIDTH + k)),
                        ray.tmin,
                        tmax,
                    );
                    if t != inf() {
                        e_ref[m] = child;
                        e_t[m] = t;
                        m += 1u;
                    }
                }
                if m == 1u {
                    node = e_ref[0];
                    continue;
                }
                if m > 1u {
                    if !ANY {
                        // Nearest first; equal distances keep lane order.
                        for (var i = 1u; i < m; i++) {
                            let t = e_t[i];
                            let c = e_ref[i];
                            var j = i;
                            while j > 0u && e_t[j - 1u] > t {
                                e_t[j] = e_t[j - 1u];
                                e_ref[j] = e_ref[j - 1u];
                                j -= 1u;
                            }
                            e_t[j] = t;
                            e_ref[j] = c;
                        }
                    }
                    for (var i = m - 1u; i > 0u; i--) {
                        stack_ref[sp] = e_ref[i];
                        stack_t[sp] = e_t[i];
                        sp += 1u;
                    }
                    node = e_ref[0];
                    continue;
                }
            }
            // The nearest pending child still in reach.
            var found = false;
            while sp > 0u {
                sp -= 1u;
                if stack_t[sp] <= tmax {
                    node = stack_ref[sp];
                    found = true;
                    break;
                }
            }
            if !found {
                break;
            }
        }
    }
    finish(id);
}
