//! Large read-mostly arrays on 2 MiB pages.
//!
//! A traversal reads nodes and triangles scattered over tens of megabytes;
//! on 4 KiB pages nearly every such read past the first few megabytes also
//! misses the TLB and walks the page tables. Linux backs memory with 2 MiB
//! pages (transparent huge pages) where a program asks for them with
//! `madvise(MADV_HUGEPAGE)` (Debian's default THP mode is `madvise`), and
//! `MADV_COLLAPSE` (Linux 6.1 and later) moves memory already written onto
//! such pages at once. Embree asks for huge pages for the same reason.
//!
//! [`vec_with_capacity`] and [`arc_from_fn`] ask before an array's first
//! write, so that its pages fault in 2 MiB at a time and nothing is copied:
//! for arrays whose size is known in advance. [`advise`] asks for an array
//! already built (both advices, on its 2 MiB-aligned part); the kernel then
//! copies what sits on small pages. Contents never change. Where the kernel
//! refuses (an older kernel, THP `never`, no free huge pages) an array stays
//! on small pages: nothing but speed depends on it. `RAYTREE_HUGE_PAGES=0`
//! turns it all off (to measure what it pays: `raytree bench peers`,
//! `examples/huge_pages.rs`).
//!
//! Measured (dragon.obj, 871k triangles, one thread, THP `madvise`):
//! `ARCHITECTURE.md`, "Huge pages".

use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;

/// The huge page size this module aligns to: 2 MiB (x86-64 and aarch64
/// with 4 KiB base pages).
pub const HUGE_PAGE: usize = 2 << 20;

/// 0: not yet read from the environment; 1: on; 2: off.
static STATE: AtomicU8 = AtomicU8::new(0);

/// Whether [`advise`] asks for huge pages: as [`set_enabled`] last said,
/// else unless `RAYTREE_HUGE_PAGES` is `0`, `off` or `false`.
pub fn enabled() -> bool {
    match STATE.load(Ordering::Relaxed) {
        1 => true,
        2 => false,
        _ => {
            let off = matches!(
                std::env::var("RAYTREE_HUGE_PAGES").as_deref(),
                Ok("0" | "off" | "false")
            );
            // A racing `set_enabled` wins over the environment.
            let _ = STATE.compare_exchange(
                0,
                if off { 2 } else { 1 },
                Ordering::Relaxed,
                Ordering::Relaxed,
            );
            STATE.load(Ordering::Relaxed) == 1
        }
    }
}

/// Turns [`advise`] on or off for this process (arrays built from now on;
/// for benchmarks that compare both in one run).
pub fn set_enabled(on: bool) {
    STATE.store(if on { 1 } else { 2 }, Ordering::Relaxed);
}

/// What [`advise`] does on this machine, for benchmark reports: `"huge
/// pages asked for (THP madvise)"` with the kernel's transparent huge page
/// mode, or why not.
pub fn describe() -> String {
    if !enabled() {
        return "huge pages off (RAYTREE_HUGE_PAGES)".to_owned();
    }
    if !cfg!(target_os = "linux") {
        return "huge pages not asked for (not Linux)".to_owned();
    }
    // "always [madvise] never": the bracketed word is the mode in force.
    let mode = std::fs::read_to_string("/sys/kernel/mm/transparent_hugepage/enabled")
        .ok()
        .and_then(|s| Some(s.split_once('[')?.1.split_once(']')?.0.to_owned()))
        .unwrap_or_else(|| "unknown".to_owned());
    format!("huge pages asked for (THP {mode})")
}

/// The 2 MiB-aligned part `[start, end)` of the bytes of `data`, if any.
fn aligned_span<T>(data: &[T]) -> Option<(usize, usize)> {
    let first = data.as_ptr() as usize;
    let last = first + std::mem::size_of_val(data);
    let start = first.checked_next_multiple_of(HUGE_PAGE)?;
    let end = last / HUGE_PAGE * HUGE_PAGE;
    (end > start).then_some((start, end))
}

/// Asks the kernel to keep the 2 MiB-aligned part of `data` on huge pages
/// (see the module's text), moving what is on small pages now; returns the
/// bytes it was asked about (0 for an array too small to hold an aligned
/// 2 MiB page, off Linux, or when [`enabled`] is false). Never changes
/// `data`'s contents; failures are ignored. Quick for memory that
/// [`vec_with_capacity`] or [`arc_from_fn`] prepared (already on huge
/// pages); for memory already written on small pages the kernel copies it.
pub fn advise<T>(data: &[T]) -> usize {
    if !enabled() {
        return 0;
    }
    let Some((start, end)) = aligned_span(data) else {
        return 0;
    };
    os::advise(start, end - start, true);
    end - start
}

/// Asks for huge pages under memory not yet written, so that its first
/// writes fault in 2 MiB pages (nothing is copied).
fn prepare<T>(uninit: &[MaybeUninit<T>]) {
    if enabled() {
        if let Some((start, end)) = aligned_span(uninit) {
            os::advise(start, end - start, false);
        }
    }
}

/// An empty vector with room for `n` elements whose memory is asked onto
/// huge pages before anything is written to it: for a structure's arrays
/// whose size is known (or bounded) before they are filled. Where the
/// allocator may hand back memory already written on small pages (a reused
/// heap block), or the vector may outgrow `n`, the caller also [`advise`]s
/// the finished array: quick when this advice took.
pub fn vec_with_capacity<T>(n: usize) -> Vec<T> {
    let mut v = Vec::with_capacity(n);
    prepare(v.spare_capacity_mut());
    v
}

/// `[f(0), f(1), ..., f(n - 1)]` in one shared allocation on huge pages
/// (the scene's triangles).
pub fn arc_from_fn<T>(n: usize, mut f: impl FnMut(usize) -> T) -> Arc<[T]> {
    let mut a = Arc::<[T]>::new_uninit_slice(n);
    let slots = Arc::get_mut(&mut a).expect("a new Arc has one owner");
    prepare(slots);
    for (i, slot) in slots.iter_mut().enumerate() {
        slot.write(f(i));
    }
    // SAFETY: every one of the `n` elements was written in the loop above
    // (a panic in `f` unwinds before this line and frees the slice without
    // reading it).
    unsafe { a.assume_init() }
}

#[cfg(target_os = "linux")]
mod os {
    /// `MADV_COLLAPSE` (Linux 6.1), absent from older libc crates' lists.
    const MADV_COLLAPSE: libc::c_int = 25;

    /// MADV_HUGEPAGE, then MADV_COLLAPSE when `collapse` (memory already
    /// written).
    pub(super) fn advise(start: usize, len: usize, collapse: bool) {
        let p = start as *mut libc::c_void;
        // SAFETY: [start, start + len) lies inside one live allocation the
        // caller borrows (`aligned_span` rounds inwards; written or not), and both advices
        // only choose the page size backing it: the kernel keeps every byte
        // (MADV_COLLAPSE copies the small pages' contents into the huge
        // page). An error (EINVAL on an old kernel, ENOMEM, EAGAIN) leaves
        // the memory as it was.
        unsafe {
            libc::madvise(p, len, libc::MADV_HUGEPAGE);
            if collapse {
                libc::madvise(p, len, MADV_COLLAPSE);
            }
        }
    }
}

#[cfg(not(target_os = "linux"))]
mod os {
    pub(super) fn advise(_start: usize, _len: usize, _collapse: bool) {}
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_span_is_the_aligned_inside_of_the_array() {
        let v = vec![7u8; 5 * HUGE_PAGE];
        let (start, end) = aligned_span(&v).unwrap();
        let first = v.as_ptr() as usize;
        assert_eq!(start % HUGE_PAGE, 0);
        assert_eq!(end % HUGE_PAGE, 0);
        assert!(start >= first && end <= first + v.len());
        assert!(start - first < HUGE_PAGE && first + v.len() - end < HUGE_PAGE);
        assert!(aligned_span(&v[..HUGE_PAGE / 2]).is_none());
        assert!(aligned_span::<u8>(&[]).is_none());
    }

    #[test]
    fn prepared_memory_holds_what_is_written() {
        let a = arc_from_fn(HUGE_PAGE, |i| i as u32 ^ 0x5bd1e995);
        assert!(a
            .iter()
            .enumerate()
            .all(|(i, &x)| x == i as u32 ^ 0x5bd1e995));
        assert_eq!(a.len(), HUGE_PAGE);
        let mut v = vec_with_capacity::<u64>(HUGE_PAGE / 2);
        assert!(v.is_empty() && v.capacity() >= HUGE_PAGE / 2);
        v.extend(0..HUGE_PAGE as u64 / 2);
        assert!(v.iter().enumerate().all(|(i, &x)| x == i as u64));
        assert_eq!(advise(&v) % HUGE_PAGE, 0);
    }

    #[test]
    fn advice_keeps_the_contents() {
        let v: Vec<u32> = (0..3 * HUGE_PAGE as u32 / 4)
            .map(|i| i.wrapping_mul(2654435761))
            .collect();
        let before = v.clone();
        let asked = advise(&v);
        assert!(!enabled() || asked >= HUGE_PAGE, "{asked} bytes");
        assert_eq!(v, before);
    }
}
