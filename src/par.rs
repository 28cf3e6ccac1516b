//! Parallel maps whose rayon machinery is compiled once per item and result
//! type, with the per-item work behind a `dyn Fn`.
//!
//! A rayon pipeline written inside a function generic over the structure
//! ([`crate::structures::Accel`]) is compiled again for every structure and
//! sink: measured on the core crate, rayon's adapters instantiated per
//! structure were about a third of its compile time. Calling one of these
//! instead keeps the kernels monomorphized (the closure is) while rayon's
//! part is shared; the indirect call per item (a tile, a chunk of rays)
//! costs nothing next to the item's work. Results keep the items' order.

use rayon::prelude::*;

/// `f` of every item of `items`, in parallel, in order.
pub fn map<I: Sync, O: Send>(items: &[I], f: &(dyn Fn(&I) -> O + Sync)) -> Vec<O> {
    items.par_iter().map(f).collect()
}

/// `f` of every item of `items`, consumed, in parallel, in order.
pub fn map_owned<I: Send, O: Send>(items: Vec<I>, f: &(dyn Fn(I) -> O + Sync)) -> Vec<O> {
    items.into_par_iter().map(f).collect()
}

/// `f` of every chunk of `chunk` items of `items` (the last one shorter),
/// in parallel, in order.
///
/// # Panics
/// When `chunk` is 0.
pub fn map_chunks<I: Sync, O: Send>(
    items: &[I],
    chunk: usize,
    f: &(dyn Fn(&[I]) -> O + Sync),
) -> Vec<O> {
    items.par_chunks(chunk).map(f).collect()
}

/// `f` of every index in `0..n`, in parallel, in order.
pub fn map_range<O: Send>(n: usize, f: &(dyn Fn(usize) -> O + Sync)) -> Vec<O> {
    (0..n).into_par_iter().map(f).collect()
}

/// `f` of every index in `0..n`, in parallel, until one fails: `Ok` when
/// every call succeeded, else one of the errors (which one, when several
/// fail, depends on the threads' timing).
pub fn try_for_each_index<E: Send>(
    n: usize,
    f: &(dyn Fn(usize) -> Result<(), E> + Sync),
) -> Result<(), E> {
    (0..n).into_par_iter().try_for_each(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_keep_the_items_order_on_any_thread_count() {
        let items: Vec<u64> = (0..10_007).collect();
        for threads in [1, 2, 5] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                assert_eq!(
                    map(&items, &|x| x * 3),
                    items.iter().map(|x| x * 3).collect::<Vec<_>>()
                );
                assert_eq!(map_owned(items.clone(), &|x| x + 1)[10_006], 10_007);
                let sums = map_chunks(&items, 1000, &|c| c.iter().sum::<u64>());
                assert_eq!(sums.len(), 11);
                assert_eq!(sums[10], (10_000..10_007).sum::<u64>());
                assert_eq!(sums.iter().sum::<u64>(), items.iter().sum::<u64>());
                assert_eq!(map_range(5, &|i| i * i), vec![0, 1, 4, 9, 16]);
                assert_eq!(
                    try_for_each_index(100, &|i| if i == 37 { Err(i) } else { Ok(()) }),
                    Err(37)
                );
                assert_eq!(try_for_each_index::<()>(100, &|_| Ok(())), Ok(()));
            });
        }
    }
}
