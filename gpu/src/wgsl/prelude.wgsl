// The part every traversal kernel shares, concatenated before its own
// source (gpu/src/kernel.rs): the bindings, the ray, the watertight triangle
// test (raytree's geometry/triangle.rs, its f32 path), the slab test
// (geometry/aabb.rs, BoxRay::test), the leaf test with the tie rule and the
// cull distance (structures/shared/leaf.rs) and the per-ray counters.
//
// Where the CPU's test leaves f32 (an edge function exactly zero, an
// ill-conditioned or tiny triangle, an overflow), the GPU does not guess: it
// marks the ray DEFERRED and stops, and the host traces that ray again on
// the CPU (see gpu/src/lib.rs).

// Closest hit (false) or any hit (true): one pipeline each.
override ANY: bool = false;

struct Params {
    // Rays in this batch.
    count: u32,
    // The structure's root reference (its own encoding).
    root: u32,
    // Threads per row of the 2D dispatch.
    row: u32,
    // 1 when the structure holds no triangles.
    empty: u32,
    // The scene box (the root's own box), xyz in each.
    lo: vec4f,
    hi: vec4f,
}

// 64 bytes, written by the host from raytree's Ray: origin, tmin,
// direction, tmax, 1/direction, the shear axes (kx | ky << 2 | kz << 4) and
// the shear constants (Sx, Sy, Sz).
struct GpuRay {
    o: vec3f,
    tmin: f32,
    d: vec3f,
    tmax: f32,
    inv: vec3f,
    k: u32,
    shear: vec3f,
    pad: u32,
}

// 32 bytes per ray: t (bits), triangle (0xffffffff: miss), u, v (bits),
// nodes, plane tests, triangle tests, status (0 done, 1 deferred).
struct Answer {
    t: u32,
    prim: u32,
    u: u32,
    v: u32,
    nodes: u32,
    planes: u32,
    triangles: u32,
    status: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> rays: array<GpuRay>;
@group(0) @binding(2) var<storage, read_write> answers: array<Answer>;
// Nine f32 per triangle, a b c, mesh order.
@group(0) @binding(3) var<storage, read> tris: array<f32>;
// The sign-terminated leaf list (the wide layouts: their triangle blocks).
@group(0) @binding(4) var<storage, read> index: array<u32>;
// The structure's node words, exactly as the CPU stores them.
@group(0) @binding(5) var<storage, read> nodes: array<u32>;

const LAST: u32 = 0x80000000u;
const NONE: u32 = 0xffffffffu;
const MISS: i32 = 0;
const HIT: i32 = 1;
const DEFER: i32 = 2;

// Per-ray state of the invocation.
var<private> ray: GpuRay;
// The reciprocal scaled for the min and for the max plane of each axis
// (`BoxRay`'s inv_lo and inv_hi: `slab_reciprocals`, no widening per box).
var<private> inv_lo: vec3f;
var<private> inv_hi: vec3f;
var<private> tmax: f32;
var<private> best_t: f32;
var<private> best_prim: u32;
var<private> best_u: f32;
var<private> best_v: f32;
var<private> n_nodes: u32;
var<private> n_planes: u32;
var<private> n_tris: u32;
var<private> deferred: bool;
// The triangle test's answer.
var<private> hit_t: f32;
var<private> hit_u: f32;
var<private> hit_v: f32;

fn inf() -> f32 {
    return bitcast<f32>(0x7f800000u);
}

fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn word_f(i: u32) -> f32 {
    return bitcast<f32>(nodes[i]);
}

// The watertight test of mesh triangle `prim` over [lo, hi].
fn triangle(prim: u32, lo: f32, hi: f32) -> i32 {
    let base = prim * 9u;
    return triangle_abc(
        vec3f(tris[base], tris[base + 1u], tris[base + 2u]),
        vec3f(tris[base + 3u], tris[base + 4u], tris[base + 5u]),
        vec3f(tris[base + 6u], tris[base + 7u], tris[base + 8u]),
        lo,
        hi,
    );
}

// The watertight test of Woop, Benthin and Wald of the triangle with
// vertices pa, pb, pc over [lo, hi], f32 path of Triangle::intersect,
// operation for operation.
fn triangle_abc(pa: vec3f, pb: vec3f, pc: vec3f, lo: f32, hi: f32) -> i32 {
    let kx = ray.k & 3u;
    let ky = (ray.k >> 2u) & 3u;
    let kz = (ray.k >> 4u) & 3u;
    let s = ray.shear;
    let a = pa - ray.o;
    let b = pb - ray.o;
    let c = pc - ray.o;
    let ax = a[kx] - s.x * a[kz];
    let ay = a[ky] - s.y * a[kz];
    let bx = b[kx] - s.x * b[kz];
    let by = b[ky] - s.y * b[kz];
    let cx = c[kx] - s.x * c[kz];
    let cy = c[ky] - s.y * c[kz];
    var u = cx * by - cy * bx;
    var v = ax * cy - ay * cx;
    var w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        // The CPU redoes the edge functions in f64: so does the GPU where
        // the adapter has f64 (EDGE_F64), else it defers the ray.
        EDGE_FALLBACK
    }
    let det = u + v + w;
    let m = abs(ax) + abs(ay) + abs(a[kz]);
    if !(abs(det) >= m * m * ILL_CONDITIONED && m >= TINY_SCALE) {
        return DEFER;
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return MISS;
    }
    if det == 0.0 {
        return MISS;
    }
    let az = s.z * a[kz];
    let bz = s.z * b[kz];
    let cz = s.z * c[kz];
    let t_scaled = u * az + v * bz + w * cz;
    // As on the CPU: T zero or subnormal (its sign may have underflowed
    // away) is deferred too.
    if !(abs(det) >= TINY_DETERMINANT && is_finite(det) && abs(t_scaled) >= MIN_NORMAL
        && is_finite(t_scaled)) {
        return DEFER;
    }
    let sign = bitcast<u32>(det) & 0x80000000u;
    let t_abs = bitcast<f32>(bitcast<u32>(t_scaled) ^ sign);
    let det_abs = abs(det);
    if t_abs < lo * det_abs || t_abs > hi * det_abs {
        return MISS;
    }
    let rcp = 1.0 / det;
    hit_t = t_scaled * rcp;
    hit_u = v * rcp;
    hit_v = w * rcp;
    return HIT;
}

// BoxRay::test: the entry distance into box [lo, hi] over [t0, t1], or +inf
// on a miss. A slab that gives NaN (origin on a plane of a zero direction
// component) is ignored by the compare-and-select.
fn box_test(lo: vec3f, hi: vec3f, t0: f32, t1: f32) -> f32 {
    var tn = t0;
    var tf = inf();
    for (var a = 0u; a < 3u; a++) {
        let l = (lo[a] - ray.o[a]) * inv_lo[a];
        let h = (hi[a] - ray.o[a]) * inv_hi[a];
        let neg = (bitcast<u32>(ray.inv[a]) & 0x80000000u) != 0u;
        let n = select(l, h, neg);
        let f = select(h, l, neg);
        tn = select(tn, n, n > tn);
        tf = select(tf, f, f < tf);
    }
    tf = select(tf, t1, t1 < tf);
    return select(inf(), tn, tn <= tf);
}

// The box of the own-box node (32 bytes, 8 words) at slot `n`.
fn own_box_test(n: u32) -> f32 {
    let at = n * 8u;
    return box_test(
        vec3f(word_f(at), word_f(at + 1u), word_f(at + 2u)),
        vec3f(word_f(at + 3u), word_f(at + 4u), word_f(at + 5u)),
        ray.tmin,
        tmax,
    );
}

fn cull_distance(t: f32) -> f32 {
    return t + abs(t) * TIE_MARGIN;
}

// Takes triangle `prim`'s test outcome `r` with the leaf test's rules (the
// tie rule, the cull distance, any hit); true when the traversal ends (any
// hit found, or the ray deferred to the CPU).
fn take(prim: u32, r: i32) -> bool {
    if r == DEFER {
        deferred = true;
        return true;
    }
    if r == HIT {
        if ANY {
            best_t = hit_t;
            best_prim = prim;
            best_u = hit_u;
            best_v = hit_v;
            return true;
        }
        if hit_t < best_t || (hit_t == best_t && prim < best_prim) {
            tmax = cull_distance(hit_t);
            best_t = hit_t;
            best_prim = prim;
            best_u = hit_u;
            best_v = hit_v;
        }
    }
    return false;
}

// The leaf test (intersect_leaf) over the sign-terminated leaf list from
// position `first`: true when the traversal ends.
fn leaf(first: u32) -> bool {
    var i = first;
    loop {
        let e = index[i];
        let prim = e & ~LAST;
        n_tris += 1u;
        if take(prim, triangle(prim, ray.tmin, tmax)) {
            return true;
        }
        if (e & LAST) != 0u {
            return false;
        }
        i += 1u;
    }
    return false;
}

// The leaf test over the wide layouts' triangle blocks (shared/tri_block.rs)
// from block `first`, bound to `index`: 40 words per block, the vertex
// coordinates as nine rows of four lanes (a x, a y, a z, b x, ..., c z),
// then the lanes' leaf-list entries (LAST on the leaf's last triangle). The
// lanes are taken in leaf order, as intersect_blocks_with answers: true
// when the traversal ends.
fn block_leaf(first: u32) -> bool {
    var at = first * 40u;
    loop {
        for (var l = 0u; l < 4u; l++) {
            let e = index[at + 36u + l];
            let prim = e & ~LAST;
            let v = at + l;
            n_tris += 1u;
            let r = triangle_abc(
                vec3f(bitcast<f32>(index[v]), bitcast<f32>(index[v + 4u]), bitcast<f32>(index[v + 8u])),
                vec3f(bitcast<f32>(index[v + 12u]), bitcast<f32>(index[v + 16u]), bitcast<f32>(index[v + 20u])),
                vec3f(bitcast<f32>(index[v + 24u]), bitcast<f32>(index[v + 28u]), bitcast<f32>(index[v + 32u])),
                ray.tmin,
                tmax,
            );
            if take(prim, r) {
                return true;
            }
            if (e & LAST) != 0u {
                return false;
            }
        }
        at += 40u;
    }
    return false;
}

// Loads ray `id` and resets the state; true if the ray enters the scene box
// (6 plane tests either way), as shared/leaf.rs's `enter`.
fn start(id: u32) -> bool {
    load(id);
    if params.empty != 0u {
        return false;
    }
    n_planes = 6u;
    // A negative or NaN tmin misses, as shared/leaf.rs's enter.
    return ray.tmin >= 0.0 && box_test(params.lo.xyz, params.hi.xyz, ray.tmin, ray.tmax) != inf();
}

// Loads ray `id` and resets the state, counters at zero.
fn load(id: u32) {
    ray = rays[id];
    for (var a = 0u; a < 3u; a++) {
        let near = ray.inv[a] * (1.0 - WIDENING_STEP);
        let far = ray.inv[a] * (1.0 + WIDENING_STEP);
        let neg = (bitcast<u32>(ray.inv[a]) & 0x80000000u) != 0u;
        inv_lo[a] = select(near, far, neg);
        inv_hi[a] = select(far, near, neg);
    }
    tmax = ray.tmax;
    best_t = inf();
    best_prim = NONE;
    best_u = 0.0;
    best_v = 0.0;
    n_nodes = 0u;
    n_planes = 0u;
    n_tris = 0u;
    deferred = false;
}

fn finish(id: u32) {
    var a: Answer;
    a.t = bitcast<u32>(best_t);
    a.prim = best_prim;
    a.u = bitcast<u32>(best_u);
    a.v = bitcast<u32>(best_v);
    a.nodes = n_nodes;
    a.planes = n_planes;
    a.triangles = n_tris;
    a.status = select(0u, 1u, deferred);
    answers[id] = a;
}

fn ray_id(gid: vec3u) -> u32 {
    return gid.x + gid.y * params.row;
}

// The sparse layout's own-box nodes (structures/sparse, shared/own_box.rs):
// 8 words per slot, bounds[6], link (bit 31 leaf; left child's slot or the
// leaf's first list position), extra (parent's slot in bits 0-29, split axis
// in bits 30-31).
fn sp_link(n: u32) -> u32 {
    return nodes[n * 8u + 6u];
}

fn sp_parent(n: u32) -> u32 {
    return nodes[n * 8u + 7u] & 0x3fffffffu;
}

fn sp_axis(n: u32) -> u32 {
    return nodes[n * 8u + 7u] >> 30u;
}

fn sibling(n: u32) -> u32 {
    return select(n - 1u, n + 1u, (n & 1u) == 1u);
}

// Walk::step's outcomes (shared/own_box.rs).
const STEP_INNER: u32 = 0u;
const STEP_LEAF: u32 = 1u;
const STEP_DONE: u32 = 2u;
// Children::of: which children were entered.
const KIDS_NONE: u32 = 0u;
const KIDS_LEFT: u32 = 1u;
const KIDS_RIGHT: u32 = 2u;
const KIDS_BOTH_LEFT_FIRST: u32 = 3u;
const KIDS_BOTH_RIGHT_FIRST: u32 = 4u;

// Set by walk_step for an inner node.
var<private> step_left: u32;
var<private> step_kids: u32;

// Walk::step over own-box node `node`: a leaf's triangles are tested, an
// inner node's two children boxes (the adjacent pair at its link) are.
fn walk_step(node: u32) -> u32 {
    return walk_step_at(node, false);
}

// walk_step, the children at slot 2·node (the implicit layout: IMPLICIT-B's
// index) when `implicit`, else at the node's link.
fn walk_step_at(node: u32, implicit: bool) -> u32 {
    n_nodes += 1u;
    let link = sp_link(node);
    if (link & LAST) != 0u {
        if leaf(link & ~LAST) {
            return STEP_DONE;
        }
        return STEP_LEAF;
    }
    n_planes += 12u;
    let left = select(link, 2u * node, implicit);
    step_left = left;
    let tl = own_box_test(left);
    let tr = own_box_test(left + 1u);
    let hl = tl != inf();
    let hr = tr != inf();
    if hl && hr {
        step_kids = select(KIDS_BOTH_LEFT_FIRST, KIDS_BOTH_RIGHT_FIRST, tr < tl);
    } else if hl {
        step_kids = KIDS_LEFT;
    } else if hr {
        step_kids = KIDS_RIGHT;
    } else {
        step_kids = KIDS_NONE;
    }
    return STEP_INNER;
}

// 64-bit words as (low, high) pairs, for SPARSE's level index and
// LAINE-k's trail (WGSL has no portable 64-bit integer).
fn u64_shl1(x: vec2u) -> vec2u {
    return vec2u(x.x << 1u, (x.y << 1u) | (x.x >> 31u));
}

fn u64_shr1(x: vec2u) -> vec2u {
    return vec2u((x.x >> 1u) | (x.y << 31u), x.y >> 1u);
}

fn u64_add(a: vec2u, b: vec2u) -> vec2u {
    let lo = a.x + b.x;
    return vec2u(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

fn u64_neg(x: vec2u) -> vec2u {
    return u64_add(~x, vec2u(1u, 0u));
}

fn u64_nonzero(x: vec2u) -> bool {
    return (x.x | x.y) != 0u;
}

// The interval traversals' entry (shared/leaf.rs, enter_interval): the
// scene box's slabs with the ray's scaled reciprocals, as BoxRay::interval;
// true if the interval [enter_t0, enter_t1] is not empty and tmin is not
// negative or NaN (6 plane tests either way).
var<private> enter_t0: f32;
var<private> enter_t1: f32;

fn start_interval(id: u32) -> bool {
    if !start(id) && params.empty != 0u {
        return false;
    }
    if !(ray.tmin >= 0.0) {
        return false;
    }
    var tn = ray.tmin;
    var tf = inf();
    for (var a = 0u; a < 3u; a++) {
        let l = (params.lo[a] - ray.o[a]) * inv_lo[a];
        let h = (params.hi[a] - ray.o[a]) * inv_hi[a];
        let neg = (bitcast<u32>(ray.inv[a]) & 0x80000000u) != 0u;
        let n = select(l, h, neg);
        let f = select(h, l, neg);
        tn = select(tn, n, n > tn);
        tf = select(tf, f, f < tf);
    }
    enter_t0 = tn;
    enter_t1 = select(tf, ray.tmax, ray.tmax < tf);
    return !(enter_t0 > enter_t1);
}
