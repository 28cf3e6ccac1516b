//! Traversal algorithms over binary BVH layouts.

pub mod stack;

/// The deepest tree a fixed-size traversal stack holds: a stack traversal
/// holds at most one pending node per level.
pub const MAX_STACK_DEPTH: usize = 128;
