//! Batches of rays through a structure chosen at run time: [`Tracer`] is
//! object safe, so a program can hold a `Box<dyn Tracer>` built from a name
//! given on its command line ([`Built::tracer`]) and trace slices of rays in
//! parallel, while each structure's kernel stays monomorphized inside (the
//! blanket implementation over [`Accel`] calls it with a concrete type).

use super::{Accel, Built, StructureKind, TraversalKind};
use crate::bvh::Bvh;
use crate::error::{Error, Result};
use crate::geometry::Triangle;
use crate::geometry::{Hit, Ray};
use crate::stats::{Counters, HitCount, HitList, NoStats};
use crate::structures::sort_hits;
use rayon::prelude::*;
use std::sync::Arc;

/// Rays per parallel task: large enough that scheduling costs nothing
/// against tracing, small enough to balance 2 to 64 threads.
const CHUNK: usize = 1024;

/// A built structure behind a trait object: closest hit and any hit over
/// slices of rays, traced in parallel on rayon's current pool.
///
/// Every call answers ray `i` into slot `i`; a ray that is not
/// [`Ray::is_valid`] is a miss. Counters, when asked for, are the sums over
/// the batch (`rays` is the batch's length) and do not depend on the number
/// of threads.
pub trait Tracer: Send + Sync {
    /// The structure's name as the command line spells it (`bvh`, `dst`).
    fn name(&self) -> &'static str;

    /// Bytes of the structure itself (nodes and index lists, not the
    /// triangles).
    fn bytes(&self) -> usize;

    /// The closest hit of each ray within its `[tmin, tmax]`, ties to the
    /// smaller triangle index, into `hits` (same length as `rays`).
    ///
    /// # Errors
    /// [`Error::Invalid`] when the slices differ in length.
    fn intersect(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        counters: Option<&mut Counters>,
    ) -> Result<()>;

    /// Whether each ray hits anything within its `[tmin, tmax]` (any hit,
    /// the first one found ends the search), into `occluded`.
    ///
    /// # Errors
    /// [`Error::Invalid`] when the slices differ in length.
    fn occluded(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        counters: Option<&mut Counters>,
    ) -> Result<()>;

    /// The number of hits along each ray within its `[tmin, tmax]` (every
    /// triangle it meets), into `counts`.
    ///
    /// # Errors
    /// [`Error::Invalid`] when the slices differ in length.
    fn count_hits(
        &self,
        rays: &[Ray],
        counts: &mut [u32],
        counters: Option<&mut Counters>,
    ) -> Result<()>;

    /// Every hit along every ray within its `[tmin, tmax]`: the hits of ray
    /// `i` are `hits[offsets[i]..offsets[i + 1]]`, nearest first, equal
    /// distances by the smaller triangle index. `offsets` has `rays.len() + 1`
    /// entries, the first 0.
    fn list_hits(&self, rays: &[Ray], counters: Option<&mut Counters>) -> HitLists;
}

/// Every hit of a batch of rays, in one flat list with per-ray offsets
/// ([`Tracer::list_hits`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HitLists {
    /// The hits of every ray, ray after ray.
    pub hits: Vec<Hit>,
    /// `rays + 1` offsets into `hits`: ray `i`'s hits are
    /// `hits[offsets[i]..offsets[i + 1]]`.
    pub offsets: Vec<usize>,
}

impl HitLists {
    /// The hits of ray `i`.
    pub fn of(&self, i: usize) -> &[Hit] {
        &self.hits[self.offsets[i]..self.offsets[i + 1]]
    }
}

fn same_length(rays: usize, out: usize) -> Result<()> {
    if rays == out {
        Ok(())
    } else {
        Err(Error::Invalid(format!(
            "{rays} rays but room for {out} answers: the slices must have the same length"
        )))
    }
}

/// Runs `one` over every ray into its slot, in parallel; with counters,
/// each chunk counts into its own [`Counters`] and the sums are added.
///
/// The per-structure part is only the loop over a chunk; the parallel
/// machinery ([`par_chunks`], [`par_chunks_counted`]) is compiled once per
/// answer type, not once per structure and query: rayon's adapters
/// instantiated for every structure cost a third of the core crate's
/// compile time, and one indirect call per chunk of 1024 rays costs
/// nothing.
fn batch<A: Accel, T: Send>(
    accel: &A,
    rays: &[Ray],
    out: &mut [T],
    counters: Option<&mut Counters>,
    one: impl Fn(&A, &Ray, &mut Counters) -> T + Sync,
    one_uncounted: impl Fn(&A, &Ray) -> T + Sync,
) -> Result<()> {
    same_length(rays.len(), out.len())?;
    match counters {
        None => par_chunks(rays, out, &|r, o| {
            for (ray, slot) in r.iter().zip(o) {
                *slot = one_uncounted(accel, ray);
            }
        }),
        Some(total) => {
            *total += par_chunks_counted(rays, out, &|r, o, c| {
                for (ray, slot) in r.iter().zip(o) {
                    *slot = one(accel, ray, c);
                }
            });
            total.rays += rays.len() as u64;
        }
    }
    Ok(())
}

/// `chunk` over matching chunks of `rays` and `out` (same length), in
/// parallel.
fn par_chunks<T: Send>(rays: &[Ray], out: &mut [T], chunk: &(dyn Fn(&[Ray], &mut [T]) + Sync)) {
    rays.par_chunks(CHUNK)
        .zip(out.par_chunks_mut(CHUNK))
        .for_each(|(r, o)| chunk(r, o));
}

/// A chunk's work with its counters: rays, their slots, the chunk's sums.
type CountedChunk<'a, T> = dyn Fn(&[Ray], &mut [T], &mut Counters) + Sync + 'a;

/// [`par_chunks`] with a [`Counters`] per chunk; their sum.
fn par_chunks_counted<T: Send>(
    rays: &[Ray],
    out: &mut [T],
    chunk: &CountedChunk<'_, T>,
) -> Counters {
    rays.par_chunks(CHUNK)
        .zip(out.par_chunks_mut(CHUNK))
        .map(|(r, o)| {
            let mut c = Counters::default();
            chunk(r, o, &mut c);
            c
        })
        .reduce(Counters::default, |mut a, b| {
            a += b;
            a
        })
}

impl<A: Accel> Tracer for A {
    fn name(&self) -> &'static str {
        Accel::name(self)
    }

    fn bytes(&self) -> usize {
        Accel::bytes(self)
    }

    fn intersect(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        counters: Option<&mut Counters>,
    ) -> Result<()> {
        batch(
            self,
            rays,
            hits,
            counters,
            |a, r, c| a.closest_hit(r, c),
            |a, r| a.closest_hit(r, &mut NoStats),
        )
    }

    fn occluded(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        counters: Option<&mut Counters>,
    ) -> Result<()> {
        batch(
            self,
            rays,
            occluded,
            counters,
            |a, r, c| a.any_hit(r, c).is_some(),
            |a, r| a.any_hit(r, &mut NoStats).is_some(),
        )
    }

    fn count_hits(
        &self,
        rays: &[Ray],
        counts: &mut [u32],
        counters: Option<&mut Counters>,
    ) -> Result<()> {
        batch(
            self,
            rays,
            counts,
            counters,
            |a, r, c| {
                let mut sink = HitCount::new(&mut *c);
                a.all_hits(r, &mut sink);
                sink.count
            },
            |a, r| a.count_hits(r),
        )
    }

    fn list_hits(&self, rays: &[Ray], counters: Option<&mut Counters>) -> HitLists {
        let mut lists: Vec<Vec<Hit>> = vec![Vec::new(); rays.len()];
        batch(
            self,
            rays,
            &mut lists,
            counters,
            |a, r, c| {
                let mut sink = HitList {
                    hits: Vec::new(),
                    inner: &mut *c,
                };
                a.all_hits(r, &mut sink);
                sort_hits(&mut sink.hits);
                sink.hits
            },
            |a, r| a.list_hits(r),
        )
        .expect("one list per ray");
        let mut offsets = Vec::with_capacity(rays.len() + 1);
        offsets.push(0);
        for l in &lists {
            offsets.push(offsets.last().unwrap() + l.len());
        }
        HitLists {
            hits: lists.into_iter().flatten().collect(),
            offsets,
        }
    }
}

/// Builds the structure named `name` from `bvh` as a trait object:
/// a structure's name (`bvh`, `dst`, `cbvh`: see [`StructureKind`]), or
/// `bvh/` and a traversal's name (`bvh/laine-4`: see [`TraversalKind`]);
/// `bvh` alone traverses with STACK.
///
/// # Errors
/// [`Error::Invalid`] for an unknown name (listing the known ones) or a
/// traversal given to a structure that has its own; the structure's own
/// conversion errors (a tree too deep for a layout).
pub fn tracer(name: &str, bvh: &Bvh, triangles: Arc<[Triangle]>) -> Result<Box<dyn Tracer>> {
    let (s, t) = name.split_once('/').unwrap_or((name, "stack"));
    let invalid = |e: crate::names::UnknownName| Error::Invalid(e.to_string());
    let structure: StructureKind = s.parse().map_err(invalid)?;
    let traversal: TraversalKind = t.parse().map_err(invalid)?;
    Ok(Built::new(structure, traversal, bvh, triangles)?.0.tracer())
}

impl Built {
    /// The structure as a trait object for batches.
    pub fn tracer(self) -> Box<dyn Tracer> {
        match self {
            Built::Bvh(a) => Box::new(a),
            Built::StackOnSparse(a) => Box::new(a),
            Built::Sparse(a) => Box::new(a),
            Built::Hapala(a) => Box::new(a),
            Built::Laine0(a) => Box::new(a),
            Built::Laine1(a) => Box::new(a),
            Built::Laine2(a) => Box::new(a),
            Built::Laine4(a) => Box::new(a),
            Built::Laine8(a) => Box::new(a),
            Built::Paired(p) => p.tracer(),
            Built::ImplicitA(a) => Box::new(a),
            Built::ImplicitB(a) => Box::new(a),
            Built::Dst(a) => Box::new(a),
            Built::Bih(a) => Box::new(a),
            Built::Htree(a) => Box::new(a),
            Built::Cbvh(a) => Box::new(a),
            Built::Bvh4(a) => Box::new(a),
            Built::Bvh8(a) => Box::new(a),
            Built::Cwbvh(a) => Box::new(a),
            Built::Brute(a) => Box::new(a),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{BuildOptions, Builder, Bvh};
    use crate::scene::Scene;
    use crate::structures::{StructureKind, TraversalKind};
    use glam::Vec3;

    fn rays(scene: &Scene, n: usize) -> Vec<Ray> {
        let mut rng = crate::rng::Pcg32::new(19, 1);
        let c = scene.mesh.bounds().center();
        let r = scene.mesh.bounds().extent().length();
        (0..n)
            .map(|i| {
                let o = c + Vec3::new(rng.range(-1.0, 1.0), 1.0, rng.range(-1.0, 1.0)) * r;
                let target = scene.triangles[i % scene.triangles.len()].centroid();
                Ray::new(
                    o,
                    target - o,
                    0.0,
                    if i % 5 == 0 { 0.5 } else { f32::INFINITY },
                )
            })
            .collect()
    }

    #[test]
    fn batches_answer_as_single_rays_on_any_thread_count() {
        let scene = Scene::from_spec("chess:3000").unwrap();
        let bvh = Bvh::build(&scene.triangles, &BuildOptions::new(Builder::Sah));
        let mut rays = rays(&scene, 5000);
        rays[7] = Ray::infinite(Vec3::NAN, Vec3::X);
        for (s, t) in [
            (StructureKind::Bvh, TraversalKind::Stack),
            (StructureKind::Bvh, TraversalKind::Laine2),
            (StructureKind::Dst, TraversalKind::Stack),
        ] {
            let (built, _) = Built::new(s, t, &bvh, scene.triangles.clone()).unwrap();
            let (want, want_any, want_counts) = built.with(Single(&rays));
            let tracer: Box<dyn Tracer> = built.tracer();
            assert_eq!(tracer.name(), s.name());
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let mut hits = vec![None; rays.len()];
                let mut occluded = vec![false; rays.len()];
                let mut c = Counters::default();
                pool.install(|| {
                    tracer.intersect(&rays, &mut hits, Some(&mut c)).unwrap();
                    tracer.occluded(&rays, &mut occluded, None).unwrap();
                });
                assert_eq!(hits, want, "{} {threads} threads", s.name());
                assert_eq!(occluded, want_any);
                assert_eq!(c, want_counts);
                assert!(hits[7].is_none());
            }
            let mut short = vec![None; 3];
            assert!(tracer.intersect(&rays, &mut short, None).is_err());
        }
        // By name.
        let t = super::tracer("bvh/laine-2", &bvh, scene.triangles.clone()).unwrap();
        assert_eq!(t.name(), "bvh");
        assert_eq!(
            super::tracer("dst", &bvh, scene.triangles.clone())
                .unwrap()
                .name(),
            "dst"
        );
        let e = super::tracer("bvh/laine-3", &bvh, scene.triangles.clone())
            .err()
            .unwrap();
        assert!(e.to_string().contains("unknown traversal 'laine-3'"), "{e}");
        assert!(super::tracer("dst/sparse", &bvh, scene.triangles.clone()).is_err());
    }

    struct Single<'a>(&'a [Ray]);

    impl crate::structures::WithAccel for Single<'_> {
        type Output = (Vec<Option<Hit>>, Vec<bool>, Counters);
        fn run<A: Accel>(self, a: &A) -> Self::Output {
            let mut c = Counters::default();
            let hits = self.0.iter().map(|r| a.closest_hit(r, &mut c)).collect();
            c.rays = self.0.len() as u64;
            let any = self
                .0
                .iter()
                .map(|r| a.any_hit(r, &mut NoStats).is_some())
                .collect();
            (hits, any, c)
        }
    }
}
