//! Acceleration structures, one folder each: its node layout and encoding,
//! its conversion from the canonical [`crate::bvh::Bvh`] and its traversal
//! kernels. Every one answers [`Accel`]; [`registry`] names them all;
//! [`Tracer`] traces batches through one chosen by name at run time.
//! What several share sits one level below them, in [`shared`].
//!
//! | folder | structure | traversals | paper |
//! |---|---|---|---|
//! | `bvh/` | uncompressed binary BVH, 52-byte inner nodes | STACK | Lin et al. 2019, §5 |
//! | `sparse/` | own-box nodes with parent links | SPARSE, HAPALA, LAINE-k, STACK | Barringer and Akenine-Möller 2013, §3, Alg. 4 |
//! | `implicit/` | own-box nodes at heap positions | IMPLICIT-A, IMPLICIT-B | Barringer and Akenine-Möller 2013, §2, Alg. 2, 3 |
//! | `dst/` | dual-split tree, 4/12-byte nodes | interval traversal | Lin et al. 2019 |
//! | `bih/` | bounding interval hierarchy (dual-split encoding) | interval traversal | Wächter and Keller 2006 |
//! | `htree/` | H-tree | interval traversal | Havran et al. 2006 (Lin et al.'s baseline) |
//! | `cbvh/` | Compact BVH, shared planes, 32-byte nodes | stack | Fabianowski and Dingliana 2009 (Lin et al.'s baseline) |
//! | `wide/` | `bvh4`, `bvh8`: 4- and 8-wide nodes collapsed by SAH, child boxes side by side | nearest-first stack with distances, every SIMD path ([`simd`]) | Ylitie et al. 2017, §3.1 (collapse) |
//! | `cwbvh/` | compressed 8-wide BVH: 80-byte nodes, child boxes in 8-bit planes | the wide kernel on decoded boxes | Ylitie et al. 2017, §3.2–3.3 |
//! | `brute/` | every triangle: the oracle | — | — |

mod batch;
pub mod bih;
pub mod brute;
pub mod bvh;
pub mod cbvh;
pub mod cwbvh;
pub mod dst;
pub mod htree;
pub mod implicit;
pub mod registry;
pub mod shared;
pub mod sparse;
pub mod wide;

pub use batch::{tracer, HitLists, Tracer};
pub use bih::Bih;
pub use brute::BruteForce;
pub use bvh::BinaryBvh;
pub use cbvh::CompactBvh;
pub use cwbvh::CwBvh;
pub use dst::DualSplitTree;
pub use htree::HTree;
pub use implicit::ImplicitBvh;
pub use registry::{
    check, state_bytes, Built, LayoutOptions, OnPaired, StructureInfo, StructureKind,
    TraversalKind, WithAccel,
};
pub use shared::leaf::{leaf_triangles, LAST};
pub use shared::simd::{self, SimdPath};
pub use shared::{stack_capacity, MAX_STACK_DEPTH};
pub use sparse::{PairedBvh, SparseBvh};
pub use wide::{Bvh4, Bvh8, WideBvh};

use crate::geometry::{Hit, Ray, Triangle};
use crate::stats::{HitCount, HitList, NoStats, Stats};

/// What every structure answers. The statistics sink is a generic parameter,
/// so that tracing with [`crate::stats::NoStats`] compiles the counting away.
pub trait Accel: Send + Sync {
    /// The structure's name as the command line spells it (`bvh`, `brute`).
    fn name(&self) -> &'static str;

    /// Bytes of the structure itself: nodes and triangle index lists, not the
    /// triangles, which every structure shares.
    fn bytes(&self) -> usize;

    /// The nearest hit within `[ray.tmin, ray.tmax]`; on equal distances, the
    /// smaller triangle index (see [`Hit::beats`]).
    fn closest_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit>;

    /// Some hit within `[ray.tmin, ray.tmax]`; the first one found ends the
    /// search.
    fn any_hit<S: Stats>(&self, ray: &Ray, stats: &mut S) -> Option<Hit>;

    /// [`Accel::closest_hit`], and the hit triangle's vertices where the
    /// structure reads them from a copy in the leaf that gave the hit
    /// (`bvh4`, `bvh8`, `cwbvh`: bit for bit the mesh's, from a cache line
    /// the trace has just read, where the mesh's array would be a cache
    /// miss per hit); `None` for the vertices elsewhere, whose callers read
    /// the mesh.
    fn closest_hit_triangle<S: Stats>(
        &self,
        ray: &Ray,
        stats: &mut S,
    ) -> Option<(Hit, Option<Triangle>)> {
        self.closest_hit(ray, stats).map(|h| (h, None))
    }

    /// Every hit within `[ray.tmin, ray.tmax]`, each handed to `sink`'s
    /// [`Stats::hit`] in the order the traversal finds it, which is any
    /// order. `sink` must want hits ([`Stats::HITS`], as
    /// [`crate::stats::HitList`] and [`crate::stats::HitCount`] do): the
    /// closest-hit traversal then neither shortens the ray nor stops.
    ///
    /// # Panics
    /// If `S::HITS` is not set.
    fn all_hits<S: Stats>(&self, ray: &Ray, sink: &mut S) {
        assert!(
            S::HITS,
            "all_hits needs a sink that wants hits (Stats::HITS)"
        );
        let none = self.closest_hit(ray, sink);
        debug_assert!(none.is_none());
    }

    /// The number of hits within `[ray.tmin, ray.tmax]` (every triangle the
    /// ray meets, counted once).
    fn count_hits(&self, ray: &Ray) -> u32 {
        let mut sink = HitCount::<NoStats>::default();
        self.all_hits(ray, &mut sink);
        sink.count
    }

    /// Every hit within `[ray.tmin, ray.tmax]`, nearest first, equal
    /// distances by the smaller triangle index.
    fn list_hits(&self, ray: &Ray) -> Vec<Hit> {
        let mut sink = HitList::<NoStats>::default();
        self.all_hits(ray, &mut sink);
        sort_hits(&mut sink.hits);
        sink.hits
    }
}

/// Sorts hits nearest first, equal distances by the smaller triangle index:
/// the order [`Accel::list_hits`] returns.
pub fn sort_hits(hits: &mut [Hit]) {
    hits.sort_unstable_by(|a, b| a.t.total_cmp(&b.t).then(a.prim.cmp(&b.prim)));
}
