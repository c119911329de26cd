//! (in progress)
use super::{Mlcp, SolveStats, Variant, OrderingKind};
/// Options (in progress).
#[derive(Debug, Clone, Default)]
pub struct SolverOptions { pub variant: Variant, pub ordering: OrderingKind }
/// Solver (in progress).
#[derive(Debug, Default)]
pub struct Solver { pub stats: SolveStats }
impl Solver { pub fn solve(&mut self, _p: &Mlcp) {} }
