//! The parallel loops behind the Python queries, free of Python: rays are
//! read straight from the caller's numpy buffer (float32 or float64, six
//! values per ray), traced by a structure as its concrete type
//! ([`WithAccel`], so each kernel stays monomorphized) and answered straight
//! into the output buffers, chunk by chunk on rayon's current pool.
//!
//! Every loop writes ray `i`'s answer into slot `i` and nothing else, so the
//! answers do not depend on the number of threads.

use rayon::prelude::*;
use raytree::geometry::{Hit, Ray, Triangle};
use raytree::prelude::Vec3;
use raytree::stats::{Counters, HitCount, HitList, NoStats};
use raytree::structures::{sort_hits, Accel, Tracer, WithAccel};
use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicUsize, Ordering};

/// An output array's slots, not yet initialized: each query writes every
/// slot exactly once (`MaybeUninit::write`) before the array reaches
/// Python, so the arrays are made without numpy's zero fill (a serial memset
/// of 32 MB before the parallel loop on 1M rays: `cast_rays` took 0.95× the
/// time without it on two threads, 0.98× on one; see `Query::array`).
pub type Slots<'a, T> = &'a mut [MaybeUninit<T>];

/// Writes `values` into `slots` (equal lengths).
#[inline(always)]
fn write_all<T: Copy>(slots: &mut [MaybeUninit<T>], values: &[T]) {
    for (s, &v) in slots.iter_mut().zip(values) {
        s.write(v);
    }
}

/// Rays per parallel task (as the core's batch calls).
pub const CHUNK: usize = 1024;

/// The primitive (and geometry) id of a miss: `0xFFFFFFFF`, as Open3D's
/// `RaycastingScene.INVALID_ID`.
pub const INVALID_ID: u32 = u32::MAX;

/// Ray coordinates as the caller gave them: six values per ray (origin x,
/// y, z, direction x, y, z), C order.
#[derive(Clone, Copy)]
pub enum Coords<'a> {
    /// float32 values, used as they are.
    F32(&'a [f32]),
    /// float64 values, rounded to float32 ray by ray (no copy of the array).
    F64(&'a [f64]),
}

/// One end of the rays' intervals: the same for every ray, or one per ray.
#[derive(Clone, Copy)]
pub enum Bound<'a> {
    /// One value for all rays.
    All(f32),
    /// Ray `i`'s value is element `i`.
    PerRay(&'a [f32]),
}

impl Bound<'_> {
    #[inline(always)]
    fn at(self, i: usize) -> f32 {
        match self {
            Bound::All(v) => v,
            Bound::PerRay(s) => s[i],
        }
    }
}

/// The rays of a query: coordinates and interval ends.
#[derive(Clone, Copy)]
pub struct Rays<'a> {
    /// Six values per ray.
    pub coords: Coords<'a>,
    /// Start of each ray's interval (in units of its direction).
    pub tmin: Bound<'a>,
    /// End of each ray's interval.
    pub tmax: Bound<'a>,
}

impl Rays<'_> {
    /// Number of rays.
    pub fn len(&self) -> usize {
        match self.coords {
            Coords::F32(s) => s.len() / 6,
            Coords::F64(s) => s.len() / 6,
        }
    }

    /// Ray `i`'s origin, direction, tmin and tmax in float32.
    #[inline(always)]
    pub fn parts(&self, i: usize) -> (Vec3, Vec3, f32, f32) {
        let v: [f32; 6] = match self.coords {
            Coords::F32(s) => s[6 * i..6 * i + 6].try_into().expect("6 values"),
            Coords::F64(s) => std::array::from_fn(|k| s[6 * i + k] as f32),
        };
        (
            Vec3::new(v[0], v[1], v[2]),
            Vec3::new(v[3], v[4], v[5]),
            self.tmin.at(i),
            self.tmax.at(i),
        )
    }

    /// Ray `i`, noting it in `invalid` when it cannot be traced (it is then
    /// a miss: see [`Ray::new`]).
    #[inline(always)]
    fn ray(&self, i: usize, invalid: &FirstInvalid) -> Ray {
        let (o, d, tmin, tmax) = self.parts(i);
        let ray = Ray::new(o, d, tmin, tmax);
        // `Ray::new` marks a ray it cannot trace with the interval
        // [+inf, -inf] (checking that costs two compares, where
        // `Ray::is_valid` would check the parts again); a caller may give
        // that interval too, so the parts decide.
        if ray.tmin == f32::INFINITY
            && ray.tmax == f32::NEG_INFINITY
            && Ray::invalid_reason(o, d, tmin, tmax).is_some()
        {
            invalid.note(i);
        }
        ray
    }
}

/// Rays `c · CHUNK ..` of chunk `c` (`len` of them) as a `Vec<Ray>`, built
/// before any is traced: the divisions of independent rays then overlap,
/// where built one by one between traces each ray's first box test waits
/// on its own (5–7% of `cast_rays` on dragon.obj). A macro rather than a
/// function: behind a call, the collect stored each ray and copied it
/// again, and cost more than it saved (camera rays 1.09× the time).
macro_rules! chunk_rays {
    ($rays:expr, $c:expr, $len:expr, $invalid:expr) => {
        (0..$len)
            .map(|j| $rays.ray($c * CHUNK + j, $invalid))
            .collect::<Vec<Ray>>()
    };
}

/// The smallest index of a ray that could not be traced, shared by the
/// tasks of a query.
pub struct FirstInvalid(AtomicUsize);

impl Default for FirstInvalid {
    fn default() -> Self {
        FirstInvalid(AtomicUsize::new(usize::MAX))
    }
}

impl FirstInvalid {
    fn note(&self, i: usize) {
        self.0.fetch_min(i, Ordering::Relaxed);
    }

    /// The first ray that could not be traced, if any.
    pub fn get(&self) -> Option<usize> {
        let i = self.0.load(Ordering::Relaxed);
        (i != usize::MAX).then_some(i)
    }
}

/// Outputs that split into per-chunk parts, ray by ray.
pub trait Split: Sized + Send {
    /// The first `rays` rays' part and the rest.
    fn split(self, rays: usize) -> (Self, Self);
}

impl<T: Split> Split for Option<T> {
    fn split(self, rays: usize) -> (Self, Self) {
        match self {
            Some(s) => {
                let (a, b) = s.split(rays);
                (Some(a), Some(b))
            }
            None => (None, None),
        }
    }
}

/// Cuts `out` (covering `n` rays) into parts of `sizes` rays each.
fn cut<S: Split>(mut out: S, sizes: impl IntoIterator<Item = usize>) -> Vec<S> {
    let mut parts = Vec::new();
    for n in sizes {
        let (a, b) = out.split(n);
        parts.push(a);
        out = b;
    }
    parts
}

/// Chunk sizes for `n` rays: `CHUNK` each, the last one the rest.
fn chunk_sizes(n: usize) -> impl Iterator<Item = usize> {
    (0..n.div_ceil(CHUNK)).map(move |c| CHUNK.min(n - c * CHUNK))
}

/// Per-ray work counters: nodes visited, ray-plane tests (a box test
/// counts 6) and ray-triangle tests, saturated to `u32`.
pub struct Work<'a> {
    /// Nodes visited per ray.
    pub nodes: Slots<'a, u32>,
    /// Ray-plane tests per ray.
    pub planes: Slots<'a, u32>,
    /// Ray-triangle tests per ray.
    pub triangles: Slots<'a, u32>,
}

impl Split for Work<'_> {
    fn split(self, rays: usize) -> (Self, Self) {
        let (n0, n1) = self.nodes.split_at_mut(rays);
        let (p0, p1) = self.planes.split_at_mut(rays);
        let (t0, t1) = self.triangles.split_at_mut(rays);
        (
            Work {
                nodes: n0,
                planes: p0,
                triangles: t0,
            },
            Work {
                nodes: n1,
                planes: p1,
                triangles: t1,
            },
        )
    }
}

impl Work<'_> {
    #[inline(always)]
    fn set(&mut self, j: usize, c: &Counters) {
        let sat = |v: u64| v.min(u32::MAX as u64) as u32;
        self.nodes[j].write(sat(c.nodes));
        self.planes[j].write(sat(c.planes));
        self.triangles[j].write(sat(c.triangles));
    }
}

/// The unit geometric normal `(b-a)×(c-a)` of a triangle: in f32 as the
/// core's renderers compute it ([`Triangle::normal`]), and again in f64
/// where the f32 cross product's squared length leaves the normal range
/// (triangles smaller than about 1e-15 or larger than 1e15 units), so that
/// every triangle that can be hit has a unit normal.
#[inline]
pub fn unit_normal(t: &Triangle) -> Vec3 {
    let n = t.normal();
    let l2 = n.length_squared();
    if (1e-30..=1e30).contains(&l2) {
        n / l2.sqrt()
    } else {
        let (a, b, c) = (t.a.as_dvec3(), t.b.as_dvec3(), t.c.as_dvec3());
        (b - a).cross(c - a).normalize_or_zero().as_vec3()
    }
}

/// The scene's geometries as hits need them: the first triangle of each
/// (consecutive ranges covering every triangle, as
/// [`raytree::scene::Mesh::geometries`]).
pub struct Geometries {
    starts: Vec<u32>,
}

impl Geometries {
    /// The geometries of `mesh`.
    pub fn of(mesh: &raytree::scene::Mesh) -> Geometries {
        Geometries {
            starts: mesh.geometries.iter().map(|g| g.first_triangle).collect(),
        }
    }

    /// The geometry of triangle `prim` (a hit's: always in range).
    #[inline(always)]
    pub fn of_triangle(&self, prim: u32) -> u32 {
        if self.starts.len() <= 1 {
            0
        } else {
            (self.starts.partition_point(|&s| s <= prim) - 1) as u32
        }
    }
}

/// The unit normal of every triangle ([`unit_normal`]; zeros for a
/// degenerate one), made once per structure: a query reads 12 bytes per hit
/// from here instead of the 36-byte triangle, which structures whose leaves
/// keep their own copies of the triangles (bvh4, bvh8) never touch. The
/// array asks for huge pages ([`raytree::pages`]), so that a hit's normal
/// costs no page walk.
pub fn unit_normals(triangles: &[Triangle]) -> Vec<[f32; 3]> {
    let mut normals: Vec<[f32; 3]> = raytree::pages::vec_with_capacity(triangles.len());
    triangles
        .par_iter()
        .map(|t| unit_normal(t).to_array())
        .collect_into_vec(&mut normals);
    normals
}

/// Where a closest-hit query answers: one slot per ray.
pub struct ClosestOut<'a> {
    /// Hit distance, `+inf` on a miss.
    pub t: Slots<'a, f32>,
    /// Triangle index, [`INVALID_ID`] on a miss.
    pub prim: Slots<'a, u32>,
    /// The geometry hit, [`INVALID_ID`] on a miss.
    pub geom: Slots<'a, u32>,
    /// Barycentrics `u`, `v` (two per ray), zeros on a miss.
    pub uv: Slots<'a, f32>,
    /// Unit geometric normal (three per ray), zeros on a miss.
    pub normal: Slots<'a, f32>,
    /// Per-ray counters, when asked for.
    pub work: Option<Work<'a>>,
}

impl Split for ClosestOut<'_> {
    fn split(self, rays: usize) -> (Self, Self) {
        let (t0, t1) = self.t.split_at_mut(rays);
        let (p0, p1) = self.prim.split_at_mut(rays);
        let (g0, g1) = self.geom.split_at_mut(rays);
        let (u0, u1) = self.uv.split_at_mut(2 * rays);
        let (n0, n1) = self.normal.split_at_mut(3 * rays);
        let (w0, w1) = self.work.split(rays);
        (
            ClosestOut {
                t: t0,
                prim: p0,
                geom: g0,
                uv: u0,
                normal: n0,
                work: w0,
            },
            ClosestOut {
                t: t1,
                prim: p1,
                geom: g1,
                uv: u1,
                normal: n1,
                work: w1,
            },
        )
    }
}

impl ClosestOut<'_> {
    /// Ray `j`'s answer, but for its normal (gathered after the chunk).
    #[inline(always)]
    fn set(&mut self, j: usize, hit: Option<Hit>, geometries: &Geometries) {
        match hit {
            Some(h) => {
                self.t[j].write(h.t);
                self.prim[j].write(h.prim);
                self.geom[j].write(geometries.of_triangle(h.prim));
                self.uv[2 * j].write(h.u);
                self.uv[2 * j + 1].write(h.v);
            }
            None => {
                self.t[j].write(f32::INFINITY);
                self.prim[j].write(INVALID_ID);
                self.geom[j].write(INVALID_ID);
                write_all(&mut self.uv[2 * j..2 * j + 2], &[0.0; 2]);
            }
        }
    }
}

/// The closest hit of every ray ([`Accel::closest_hit`]).
pub struct Closest<'a> {
    /// The rays.
    pub rays: Rays<'a>,
    /// Their answers.
    pub out: ClosestOut<'a>,
    /// The unit normal of every triangle ([`unit_normals`]).
    pub normals: &'a [[f32; 3]],
    /// The scene's geometries (for the geometry ids).
    pub geometries: &'a Geometries,
    /// Receives the first ray that cannot be traced.
    pub invalid: &'a FirstInvalid,
}

impl WithAccel for Closest<'_> {
    type Output = ();
    fn run<A: Accel>(self, a: &A) {
        let Closest {
            rays,
            out,
            normals,
            geometries,
            invalid,
        } = self;
        let n = rays.len();
        cut(out, chunk_sizes(n))
            .into_par_iter()
            .enumerate()
            .for_each(|(c, mut o)| {
                // A structure whose leaves keep their own copies of the
                // triangles (bvh4, bvh8, cwbvh) never touches the scene's
                // arrays: it hands back the hit triangle from the leaf,
                // still in cache, and the normal is computed at once. The
                // others' normals are gathered after the chunk is traced, in
                // a loop of independent loads that the processor overlaps.
                let mut gather = false;
                for (j, ray) in chunk_rays!(rays, c, o.t.len(), invalid).iter().enumerate() {
                    let hit = match o.work.as_mut() {
                        None => a.closest_hit_triangle(ray, &mut NoStats),
                        Some(w) => {
                            let mut s = Counters::default();
                            let hit = a.closest_hit_triangle(ray, &mut s);
                            w.set(j, &s);
                            hit
                        }
                    };
                    let normal = match hit {
                        Some((_, Some(t))) => unit_normal(&t).to_array(),
                        Some((_, None)) => {
                            gather = true;
                            [0.0; 3]
                        }
                        None => [0.0; 3],
                    };
                    write_all(&mut o.normal[3 * j..3 * j + 3], &normal);
                    o.set(j, hit.map(|(h, _)| h), geometries);
                }
                if gather {
                    for (prim, normal) in o.prim.iter().zip(o.normal.chunks_exact_mut(3)) {
                        // SAFETY: the loop above wrote every ray's
                        // primitive id in this chunk (`ClosestOut::set`).
                        let prim = unsafe { prim.assume_init() };
                        write_all(normal, normals.get(prim as usize).unwrap_or(&[0.0; 3]));
                    }
                }
            });
    }
}

/// One value per ray, and optional counters.
pub struct PerRayOut<'a, T> {
    /// The answers.
    pub values: Slots<'a, T>,
    /// Per-ray counters, when asked for.
    pub work: Option<Work<'a>>,
}

impl<T: Send> Split for PerRayOut<'_, T> {
    fn split(self, rays: usize) -> (Self, Self) {
        let (v0, v1) = self.values.split_at_mut(rays);
        let (w0, w1) = self.work.split(rays);
        (
            PerRayOut {
                values: v0,
                work: w0,
            },
            PerRayOut {
                values: v1,
                work: w1,
            },
        )
    }
}

/// Whether each ray hits anything ([`Accel::any_hit`]).
pub struct Occluded<'a> {
    /// The rays.
    pub rays: Rays<'a>,
    /// `true` where a ray hits.
    pub out: PerRayOut<'a, bool>,
    /// Receives the first ray that cannot be traced.
    pub invalid: &'a FirstInvalid,
}

impl WithAccel for Occluded<'_> {
    type Output = ();
    fn run<A: Accel>(self, a: &A) {
        let Occluded { rays, out, invalid } = self;
        let n = rays.len();
        cut(out, chunk_sizes(n))
            .into_par_iter()
            .enumerate()
            .for_each(|(c, mut o)| {
                for (j, ray) in chunk_rays!(rays, c, o.values.len(), invalid)
                    .iter()
                    .enumerate()
                {
                    o.values[j].write(match o.work.as_mut() {
                        None => a.any_hit(ray, &mut NoStats).is_some(),
                        Some(w) => {
                            let mut s = Counters::default();
                            let hit = a.any_hit(ray, &mut s).is_some();
                            w.set(j, &s);
                            hit
                        }
                    });
                }
            });
    }
}

/// The number of hits along each ray ([`Accel::all_hits`]).
pub struct CountHits<'a> {
    /// The rays.
    pub rays: Rays<'a>,
    /// Hits per ray.
    pub out: PerRayOut<'a, u32>,
    /// Receives the first ray that cannot be traced.
    pub invalid: &'a FirstInvalid,
}

impl WithAccel for CountHits<'_> {
    type Output = ();
    fn run<A: Accel>(self, a: &A) {
        let CountHits { rays, out, invalid } = self;
        let n = rays.len();
        cut(out, chunk_sizes(n))
            .into_par_iter()
            .enumerate()
            .for_each(|(c, mut o)| {
                for (j, ray) in chunk_rays!(rays, c, o.values.len(), invalid)
                    .iter()
                    .enumerate()
                {
                    o.values[j].write(match o.work.as_mut() {
                        None => a.count_hits(ray),
                        Some(w) => {
                            let mut s = Counters::default();
                            let mut sink = HitCount::new(&mut s);
                            a.all_hits(ray, &mut sink);
                            let count = sink.count;
                            w.set(j, &s);
                            count
                        }
                    });
                }
            });
    }
}

/// The hits of one chunk of rays, ray after ray, nearest first.
pub struct ChunkHits {
    /// Every hit kept, ray after ray.
    pub hits: Vec<Hit>,
    /// Hits kept per ray of the chunk.
    pub counts: Vec<u32>,
}

/// Every hit along each ray ([`Accel::all_hits`]), nearest first, equal
/// distances by the smaller triangle index; at most `max_hits` per ray (the
/// nearest ones).
pub struct ListHits<'a> {
    /// The rays.
    pub rays: Rays<'a>,
    /// Per-ray counters, when asked for (they count the whole traversal,
    /// whatever `max_hits` keeps).
    pub work: Option<Work<'a>>,
    /// Most hits kept per ray.
    pub max_hits: usize,
    /// Receives the first ray that cannot be traced.
    pub invalid: &'a FirstInvalid,
}

impl WithAccel for ListHits<'_> {
    type Output = Vec<ChunkHits>;
    fn run<A: Accel>(self, a: &A) -> Vec<ChunkHits> {
        let ListHits {
            rays,
            work,
            max_hits,
            invalid,
        } = self;
        let n = rays.len();
        let sizes: Vec<usize> = chunk_sizes(n).collect();
        let works = match work {
            Some(w) => cut(w, sizes.iter().copied())
                .into_iter()
                .map(Some)
                .collect(),
            None => sizes.iter().map(|_| None).collect::<Vec<_>>(),
        };
        works
            .into_par_iter()
            .zip(sizes)
            .enumerate()
            .map(|(c, (mut w, size))| {
                let mut chunk = ChunkHits {
                    hits: Vec::new(),
                    counts: Vec::with_capacity(size),
                };
                for j in 0..size {
                    let ray = rays.ray(c * CHUNK + j, invalid);
                    let mut hits = match w.as_mut() {
                        None => a.list_hits(&ray),
                        Some(w) => {
                            let mut s = Counters::default();
                            let mut sink = HitList {
                                hits: Vec::new(),
                                inner: &mut s,
                            };
                            a.all_hits(&ray, &mut sink);
                            let mut hits = sink.hits;
                            sort_hits(&mut hits);
                            w.set(j, &s);
                            hits
                        }
                    };
                    hits.truncate(max_hits);
                    chunk.counts.push(hits.len() as u32);
                    chunk.hits.extend_from_slice(&hits);
                }
                chunk
            })
            .collect()
    }
}

/// Where [`ListHits`]'s answers go once their number is known: one slot
/// per hit.
pub struct ListOut<'a> {
    /// Hit distances.
    pub t: Slots<'a, f32>,
    /// Triangle indices.
    pub prim: Slots<'a, u32>,
    /// Geometry ids.
    pub geom: Slots<'a, u32>,
    /// Barycentrics `u`, `v`, two per hit.
    pub uv: Slots<'a, f32>,
    /// Unit geometric normals, three per hit.
    pub normal: Slots<'a, f32>,
    /// The ray of each hit (flat index over the rays' leading shape).
    pub ray_ids: Slots<'a, i64>,
}

impl Split for ListOut<'_> {
    fn split(self, hits: usize) -> (Self, Self) {
        let (t0, t1) = self.t.split_at_mut(hits);
        let (p0, p1) = self.prim.split_at_mut(hits);
        let (g0, g1) = self.geom.split_at_mut(hits);
        let (u0, u1) = self.uv.split_at_mut(2 * hits);
        let (n0, n1) = self.normal.split_at_mut(3 * hits);
        let (r0, r1) = self.ray_ids.split_at_mut(hits);
        (
            ListOut {
                t: t0,
                prim: p0,
                geom: g0,
                uv: u0,
                normal: n0,
                ray_ids: r0,
            },
            ListOut {
                t: t1,
                prim: p1,
                geom: g1,
                uv: u1,
                normal: n1,
                ray_ids: r1,
            },
        )
    }
}

/// Writes the chunks' hits into `out` and the per-ray offsets into
/// `splits` (`rays + 1` entries, the first 0).
pub fn fill_lists(
    chunks: &[ChunkHits],
    out: ListOut,
    splits: Slots<i64>,
    normals: &[[f32; 3]],
    geometries: &Geometries,
) {
    let mut total = 0i64;
    splits[0].write(0);
    let mut k = 1;
    for c in chunks {
        for &n in &c.counts {
            total += n as i64;
            splits[k].write(total);
            k += 1;
        }
    }
    let parts = cut(out, chunks.iter().map(|c| c.hits.len()));
    parts
        .into_par_iter()
        .zip(chunks)
        .enumerate()
        .for_each(|(c, (o, chunk))| {
            let mut h = 0;
            for (j, &count) in chunk.counts.iter().enumerate() {
                let ray = (c * CHUNK + j) as i64;
                for _ in 0..count {
                    let hit = chunk.hits[h];
                    o.t[h].write(hit.t);
                    o.prim[h].write(hit.prim);
                    o.geom[h].write(geometries.of_triangle(hit.prim));
                    o.uv[2 * h].write(hit.u);
                    o.uv[2 * h + 1].write(hit.v);
                    write_all(&mut o.normal[3 * h..3 * h + 3], &normals[hit.prim as usize]);
                    o.ray_ids[h].write(ray);
                    h += 1;
                }
            }
        });
}

/// The core's own batch call, [`Tracer::intersect`], over rays already
/// built: the baseline the Python overhead is measured against.
pub struct RustBatch<'a> {
    /// The rays, built beforehand.
    pub rays: &'a [Ray],
    /// Their closest hits.
    pub hits: &'a mut [Option<Hit>],
}

impl WithAccel for RustBatch<'_> {
    type Output = raytree::error::Result<()>;
    fn run<A: Accel>(self, a: &A) -> Self::Output {
        Tracer::intersect(a, self.rays, self.hits, None)
    }
}

/// Builds every ray of `rays` (invalid ones become misses).
pub fn build_rays(rays: &Rays) -> Vec<Ray> {
    (0..rays.len())
        .into_par_iter()
        .map(|i| {
            let (o, d, tmin, tmax) = rays.parts(i);
            Ray::new(o, d, tmin, tmax)
        })
        .collect()
}
