//! The renders of a structure chosen at run time ([`Built`]), compiled here
//! once for every structure. A caller that renders through these methods
//! does not monomorphize the render loops and kernels itself: the command
//! line's crate, for one, is compiled without optimization in the test
//! profile and still renders at the core crate's speed.

use super::{
    render, render_ao_phased, render_ao_phased_uncounted, render_uncounted, AoSettings, Integrator,
    PhasedAo, Rendered,
};
use crate::scene::Scene;
use crate::structures::{Accel, Built, WithAccel};

struct Render<'a> {
    scene: &'a Scene,
    integrator: &'a Integrator,
    size: (usize, usize),
    progress: &'a (dyn Fn(usize) + Sync),
    counted: bool,
}

impl WithAccel for Render<'_> {
    type Output = Rendered;
    fn run<A: Accel>(self, a: &A) -> Rendered {
        let (w, h) = self.size;
        if self.counted {
            render(a, self.scene, self.integrator, w, h, self.progress)
        } else {
            render_uncounted(a, self.scene, self.integrator, w, h, self.progress)
        }
    }
}

struct Phased<'a> {
    scene: &'a Scene,
    ao: &'a AoSettings,
    size: (usize, usize),
    counted: bool,
}

impl WithAccel for Phased<'_> {
    type Output = PhasedAo;
    fn run<A: Accel>(self, a: &A) -> PhasedAo {
        let (w, h) = self.size;
        if self.counted {
            render_ao_phased(a, self.scene, self.ao, w, h)
        } else {
            render_ao_phased_uncounted(a, self.scene, self.ao, w, h)
        }
    }
}

impl Built {
    /// [`render`] through the structure held: a `width × height` image of
    /// `scene`, its per-pixel work and counters; `progress` is called once
    /// per finished tile with the tile's pixel count.
    pub fn render(
        &self,
        scene: &Scene,
        integrator: &Integrator,
        width: usize,
        height: usize,
        progress: &(dyn Fn(usize) + Sync),
    ) -> Rendered {
        self.render_as(scene, integrator, (width, height), progress, true)
    }

    /// [`render_uncounted`] through the structure held: [`Built::render`]
    /// with the traversal counters compiled out (rays are still counted).
    pub fn render_uncounted(
        &self,
        scene: &Scene,
        integrator: &Integrator,
        width: usize,
        height: usize,
        progress: &(dyn Fn(usize) + Sync),
    ) -> Rendered {
        self.render_as(scene, integrator, (width, height), progress, false)
    }

    fn render_as(
        &self,
        scene: &Scene,
        integrator: &Integrator,
        size: (usize, usize),
        progress: &(dyn Fn(usize) + Sync),
        counted: bool,
    ) -> Rendered {
        self.with(Render {
            scene,
            integrator,
            size,
            progress,
            counted,
        })
    }

    /// [`render_ao_phased`] through the structure held when `counted`, else
    /// [`render_ao_phased_uncounted`] (the same image and rays, the
    /// traversal counters compiled out, for timed phases).
    pub fn render_ao_phased(
        &self,
        scene: &Scene,
        ao: &AoSettings,
        width: usize,
        height: usize,
        counted: bool,
    ) -> PhasedAo {
        self.with(Phased {
            scene,
            ao,
            size: (width, height),
            counted,
        })
    }
}
