//! What several structures share, one level below them: the
//! sign-terminated leaf list and the leaf and root tests of every traversal
//! ([`leaf`]), the own-box node of the stackless paper's layouts and the node
//! step of the seven binary traversals over it ([`own_box`]), the plane
//! interval arithmetic of the interval traversals ([`interval`]), leaves of
//! triangles tested four at a time ([`tri_block`]), the run-time choice of
//! vector instruction set ([`simd`]), and the
//! sizing of traversal stacks (here).

pub mod interval;
pub mod leaf;
pub mod own_box;
pub mod simd;
pub mod tri_block;

/// The deepest tree a fixed-size traversal stack holds: a stack traversal
/// holds at most one pending node per level.
pub const MAX_STACK_DEPTH: usize = 128;

/// The stack a tree of `depth` levels needs: 32, 64 or 128 entries. Stack
/// traversals are compiled for each size and pick theirs per tree, so that
/// a ray does not pay for clearing a stack deeper than its tree.
pub fn stack_capacity(depth: u32) -> usize {
    match depth {
        0..32 => 32,
        32..64 => 64,
        _ => MAX_STACK_DEPTH,
    }
}

/// Calls `$f::<.., N>($args)` with the stack capacity `N` for `$depth`.
macro_rules! with_stack {
    ($depth:expr, $f:ident::<$($g:ty),*; $any:ident>($($a:expr),*)) => {
        match $crate::structures::shared::stack_capacity($depth) {
            32 => $f::<$($g,)* $any, 32>($($a),*),
            64 => $f::<$($g,)* $any, 64>($($a),*),
            _ => $f::<$($g,)* $any, 128>($($a),*),
        }
    };
}
pub(crate) use with_stack;
