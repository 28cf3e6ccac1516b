// The dual-split tree (Lin et al. 2019, Algorithm 1; structures/dst/
// traverse.rs) over its own words: a header word (6-bit header, 26-bit
// offset) and, but for plain leaves, two f32 planes. The interval
// [t0, t1] is narrowed by splitting nodes (nearer child first, the farther
// one pushed with its interval) and clipped by carving nodes; popped
// entries are culled against the closest hit. Plane distances are widened
// by the ray's per-axis slack (shared/interval.rs, PlaneRay).

const OFFSET_BITS: u32 = 26u;
const OFFSET_MASK: u32 = 0x3ffffffu;
const LEAF_HEADER: u32 = 0x1cu;

var<private> slack: vec3f;
var<private> lo_bias: array<f32, 6>;
var<private> hi_bias: array<f32, 6>;

fn is_nan(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) > 0x7f800000u;
}

fn neg(a: u32) -> bool {
    return (bitcast<u32>(ray.inv[a]) & 0x80000000u) != 0u;
}

fn raise(acc: f32, t: f32) -> f32 {
    return select(acc, t, t > acc);
}

fn lower(acc: f32, t: f32) -> f32 {
    return select(acc, t, t < acc);
}

fn plane_t(a: u32, p: f32) -> f32 {
    return (p - ray.o[a]) * ray.inv[a];
}

// PlaneRay::new over the scene box.
fn plane_ray() {
    let lo = params.lo.xyz;
    let hi = params.hi.xyz;
    for (var a = 0u; a < 3u; a++) {
        let far = max(abs(lo[a] - ray.o[a]), abs(hi[a] - ray.o[a]));
        slack[a] = select(0.0, far * abs(ray.inv[a]) * SLACK, is_finite(ray.inv[a]));
    }
    for (var c = 0u; c < 6u; c++) {
        let exits = ((c & 1u) == 1u) != neg(c / 2u);
        lo_bias[c] = select(-slack[c / 2u], -inf(), exits);
        hi_bias[c] = select(inf(), slack[c / 2u], exits);
    }
}

// A carving header's face code (2·axis + max side) for plane k (0 or 1).
fn carve_face(h: u32, k: u32) -> u32 {
    if (h & 0x20u) != 0u {
        // Dual-axis: axes 00 xy, 01 xz, 11 yz (10 reads as yz); corner
        // bit k says whether plane k is the maximum.
        let pair = (h >> 2u) & 3u;
        var axis: u32;
        if k == 0u {
            axis = select(1u, 0u, pair <= 1u);
        } else {
            axis = select(2u, 1u, pair == 0u);
        }
        return 2u * axis + ((h >> k) & 1u);
    }
    return 2u * (h & 3u) + k;
}

fn carve_leaf(h: u32) -> bool {
    if (h & 0x20u) != 0u {
        return (h & 0x10u) != 0u;
    }
    return (h & 0x8u) != 0u;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let id = ray_id(gid);
    if id >= params.count {
        return;
    }
    // enter_interval: the scene box's interval (BoxRay::interval).
    if start_interval(id) {
        plane_ray();
        var stack_n: array<u32, STACK_SIZE>;
        var stack_0: array<f32, STACK_SIZE>;
        var stack_1: array<f32, STACK_SIZE>;
        var sp = 0u;
        var node = 0u;
        var t0 = enter_t0;
        var t1 = enter_t1;
        loop {
            n_nodes += 1u;
            let w = nodes[node];
            let h = w >> OFFSET_BITS;
            let offset = w & OFFSET_MASK;
            var descend = false;
            var is_leaf = false;
            if (h & 0x30u) == 0u {
                n_planes += 2u;
                let a = (h >> 2u) & 3u;
                let first = node + offset;
                let second = first + (h & 3u);
                let s = select(0u, 1u, neg(a));
                let near = select(first, second, s == 1u);
                let far = select(second, first, s == 1u);
                let near_exit = plane_t(a, word_f(node + 1u + s)) + slack[a];
                let far_entry = plane_t(a, word_f(node + 2u - s)) - slack[a];
                let hit_near = near_exit >= t0 || is_nan(near_exit);
                let hit_far = (far_entry <= t1 && far_entry < inf()) || is_nan(far_entry);
                if hit_near && hit_far {
                    stack_n[sp] = far;
                    stack_0[sp] = raise(t0, far_entry);
                    stack_1[sp] = t1;
                    sp += 1u;
                    node = near;
                    t1 = lower(t1, near_exit);
                    continue;
                }
                if hit_near {
                    node = near;
                    t1 = lower(t1, near_exit);
                    continue;
                }
                if hit_far {
                    node = far;
                    t0 = raise(t0, far_entry);
                    continue;
                }
            } else if h != LEAF_HEADER {
                n_planes += 2u;
                for (var k = 0u; k < 2u; k++) {
                    let code = carve_face(h, k);
                    let t = plane_t(code / 2u, word_f(node + 1u + k));
                    t0 = raise(t0, t + lo_bias[code]);
                    t1 = lower(t1, t + hi_bias[code]);
                }
                if t0 <= t1 && t0 < inf() {
                    descend = true;
                    is_leaf = carve_leaf(h);
                }
            } else {
                descend = true;
                is_leaf = true;
            }
            if descend {
                if !is_leaf {
                    node += offset;
                    continue;
                }
                if leaf(offset) {
                    break;
                }
            }
            // pop_live: entries beyond the closest hit are dropped.
            var found = false;
            while sp > 0u {
                sp -= 1u;
                let a0 = stack_0[sp];
                if a0 <= tmax && a0 < inf() {
                    node = stack_n[sp];
                    t0 = a0;
                    t1 = lower(stack_1[sp], tmax);
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
