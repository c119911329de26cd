//! The paper's solver (Enzenhöfer, Lefebvre, Andrews, I3D 2019, §3): block principal pivoting for the
//! boxed MLCP of one constraint island, with Cholesky row/column deletions on a skyline.
//!
//! This module knows nothing about bodies: it takes an [`Mlcp`] and returns `λ` and [`SolveStats`].
//!
//! | file | stage |
//! |---|---|
//! | `problem.rs` | the problem (eq. 3), validation, natural-map residual |
//! | `io.rs` | the MLCP text format of `MLCP_FORMAT.md` |
//! | `ordering.rs` | Cuthill–McKee / reverse Cuthill–McKee (§3.4), bandwidth and envelope |
//! | `dense.rs` | dense left-looking Cholesky, row/column deletion, solves (Alg. 1, 2) |
//! | `envelope.rs` | envelope (skyline) Cholesky, deletion on the skyline, solves (Alg. 3) |
//! | `envelope_lu.rs` | LU without pivoting on the same envelope (the interior point method's Newton matrix) |
//! | `bpp/` | block principal pivoting (eq. 4–6): `options.rs`, `solver.rs` the entry, `pivot.rs` the pivoting loop, `outer.rs` the outer friction loop, `factor.rs` the factor strategies, `safeguard.rs` the active-set and proximal safeguards, `coupled.rs` friction coupling, `ipm.rs` the interior point switch, `safe.rs` safe returned iterates |
//! | `pgs.rs` | projected Gauss–Seidel baseline |
//! | `generate.rs` | generated contact-like test problems (tests and `bench-solver`) |
//! | `reference.rs` | brute-force enumeration of index sets (test reference for small problems) |

mod bpp;
pub mod dense;
pub mod envelope;
pub mod envelope_lu;
pub mod generate;
pub mod io;
pub mod ordering;
pub mod pgs;
mod problem;
pub mod reference;
mod stats;
mod variant;

pub use bpp::{Fallback, POLISH_SWEEPS, Solver, SolverOptions};
pub use problem::{IndexState, Mlcp, MlcpError, SYMMETRY_TOL, SymCsr, effective_bounds, natural_residual};
pub use stats::{SolveStats, SolveStatus};
pub use variant::{OrderingKind, UnknownVariant, Variant};
