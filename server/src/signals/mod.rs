//! Operator-grade signals (issue 17): sensors computed every step from the solver's impulses,
//! threshold events on them, and scripted or live faults.
//!
//! | file | concept |
//! |---|---|
//! | `sensor.rs` | what a sensor measures (resolved ids, body sets) and its channels |
//! | `eval.rs` | [`Signals`]: every sensor evaluated after a step into preallocated channels |
//! | `support.rs` | the support polygon and the tipping margin (load-moment indicator) |
//! | `event.rs` | the events of a step and the declared thresholds (data) |
//! | `events.rs` | threshold crossings on channels, with sim time |
//!
//! **From impulses to forces.** The step solves for impulses `λ` (paper eq. 1–3); a row's mean
//! force (torque) over the step is `λ / h`. Row `i` acts on body `k` along its Jacobian block, so
//! the wrench a joint applies to its body A, about A's centre of mass `c_A` in world axes, is
//!
//! ```text
//!   F_A = Σ_i J_{i,A}^lin λ_i / h,     τ_A = Σ_i J_{i,A}^ang λ_i / h      (all rows of the joint:
//!                                                                       locked, limits, motors)
//! ```
//!
//! and on B the opposite force acts at the anchor. A **joint sensor** reports this wrench at the
//! anchor `p` (A's joint-frame origin) in A's joint frame `R = R_A R_{F_A}` (x = the joint axis):
//!
//! ```text
//!   f = Rᵀ F_A,     t = Rᵀ (τ_A + (c_A − p) × F_A)
//! ```
//!
//! A **cylinder** (prismatic joint) reports `f_x`, the force along its axis on A: positive pushes
//! A out (the cylinder extends against it, compression), negative pulls. A **drum** (hinge) reports
//! `t_x`, the torque about its axis that holds the drum (its motor or brake with any limit row):
//! the winch's drum torque, `R T` under a static rope tension `T` on a drum of radius `R`.
//! A **cable** reports the tension `|F_A|` of each of its ball joints from the top (`start`, or the
//! fairlead end) to the hook (`end`): a ball joint carries no torque, so `|F|` is the rope's
//! tension where the segments meet.
//!
//! **Contacts.** A contact point with normal `n` (from A to B), tangents `t₁, t₂` and impulses
//! `λ_n, λ₁, λ₂` pushes B with `F = (n λ_n + t₁ λ₁ + t₂ λ₂) / h` (A with `−F`). A **contact sum**
//! between a body set `S` and a set `W` (default: every body not in `S`) adds the force on `S` of
//! each point joining `S` to `W`, with the normal `Σ λ_n / h` and friction `Σ |(λ₁, λ₂)| / h`
//! magnitudes. A point is *open* when its normal row ends at its lower bound (`λ_n = 0`); *slip*
//! when a friction row ends at its bound `±μ λ_n` in the solver's final index set (or its impulse
//! reaches the bound within 1e-9 relative: a safeguarded solve that ends without an index set);
//! otherwise *stick*.
//!
//! **Tipping margin** (`support.rs`): the support polygon is the convex hull of the active
//! contacts between the machine's bodies `S` and the rest, projected along gravity; its margin is
//! the signed distance of the machine's centre of mass (`Σ m_k c_k / Σ m_k` over `S`, load
//! included) to the polygon's boundary, and the percentage compares the stabilizing and
//! overturning moments of the bodies of `S` about the tipping edge.
//!
//! **Allocation.** Every buffer (channel values, joint wrench accumulators, hull points, contact
//! records) is sized when the scene is built; evaluating the signals allocates nothing (the
//! zero-allocation test counts it).
//!
//! Faults (rope break, hose burst, brake fade, sticking valve, sensor dropout) act on a scene's
//! joints and actuators and live in `crate::scene` (`faults.rs`); they report here as events and
//! drop sensors out through [`Signals::set_dropout`].
//!
//! Arrows: this module reads [`crate::dynamics`]; [`crate::scene`] builds it from the scene file;
//! [`crate::serve`] publishes it. The solver never sees it.

mod eval;
mod event;
mod events;
mod sensor;
mod state;
mod support;

pub use eval::{ContactState, ContactStateKind, MAX_CONTACT_RECORDS, MAX_QUEUED_EVENTS, Signals};
pub use event::{Event, EventKind, EventName, Threshold, ThresholdDir};
pub use sensor::{BodySet, Sensor, SensorKind};
pub use state::{SignalsState, SignalsStateError};
pub use support::{SupportPolygon, TippingMargin};
