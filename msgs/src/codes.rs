//! Enumerations that travel as one-byte codes (binary frames) or as names (JSON, CLI, reports).
//!
//! | enum | code → name |
//! |---|---|
//! | [`SolverVariant`] | 0 `full`, 1 `downdate`, 2 `skyline`, 3 `skyline-refactor`, 4 `incremental`, 5 `auto`, 6 `pgs` |
//! | [`SolveStatus`] | 0 `converged`, 1 `inexact`, 2 `max-steps`, 3 `empty`, 4 `non-finite`, 5 `budget` |
//! | [`ActuatorMode`] | 0 `velocity`, 1 `position`, 2 `effort` |
//! | [`RejectReason`] | 0 `malformed`, 1 `version`, 2 `non-finite`, 3 `out-of-range`, 4 `unknown-actuator`, 5 `oversize`, 6 `stale`, 7 `other`, 8 `wrong-mode` |
//!
//! The solver variant codes are the indices of [`SOLVER_VARIANTS`](crate::SOLVER_VARIANTS); a test pins the two together.

/// Defines a `u8`-coded enum with names, `ALL`, `code`, `from_code`, `name`, `from_name`.
macro_rules! coded_enum {
    ($(#[$m:meta])* $name:ident { $($(#[$vm:meta])* $v:ident = $code:literal => $s:literal,)+ }) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
        #[repr(u8)]
        pub enum $name {
            $($(#[$vm])* $v = $code,)+
        }

        impl $name {
            /// Every value, in code order.
            pub const ALL: &'static [$name] = &[$($name::$v,)+];

            /// Wire code.
            #[inline]
            pub fn code(self) -> u8 {
                self as u8
            }

            /// The value of a wire code, if defined.
            pub fn from_code(code: u8) -> Option<Self> {
                Self::ALL.iter().copied().find(|v| v.code() == code)
            }

            /// Name used in JSON, on the CLI and in reports.
            pub fn name(self) -> &'static str {
                match self {
                    $($name::$v => $s,)+
                }
            }

            /// The value of a name, if defined (exact, case-sensitive).
            pub fn from_name(name: &str) -> Option<Self> {
                Self::ALL.iter().copied().find(|v| v.name() == name)
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl serde::Serialize for $name {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.serialize_str(self.name())
            }
        }

        impl<'de> serde::Deserialize<'de> for $name {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let s = <std::borrow::Cow<'de, str>>::deserialize(d)?;
                Self::from_name(&s).ok_or_else(|| {
                    let names: Vec<&str> = Self::ALL.iter().map(|v| v.name()).collect();
                    serde::de::Error::custom(format_args!(
                        "unknown {} {:?}, expected one of {}",
                        stringify!($name),
                        s,
                        names.join(", ")
                    ))
                })
            }
        }
    };
}

coded_enum! {
    /// Solver variant (see ARCHITECTURE.md); codes are indices of [`crate::SOLVER_VARIANTS`].
    SolverVariant {
        /// Dense refactor of `A_FF` per pivot step (paper Alg. 1).
        Full = 0 => "full",
        /// Dense `L₀` + copy + row/column deletions (Alg. 2).
        Downdate = 1 => "downdate",
        /// Cuthill–McKee + envelope + deletions (Alg. 2 + 3).
        #[default]
        Skyline = 2 => "skyline",
        /// Envelope refactor per pivot step.
        SkylineRefactor = 3 => "skyline-refactor",
        /// Refactor from the first changed row of the previous factor.
        Incremental = 4 => "incremental",
        /// Per step, the cheapest predicted of the above.
        Auto = 5 => "auto",
        /// Projected Gauss–Seidel baseline.
        Pgs = 6 => "pgs",
    }
}

coded_enum! {
    /// How an island's solve ended (the server's `SolveStatus`).
    SolveStatus {
        /// Index set settled, residual within tolerance.
        #[default]
        Converged = 0 => "converged",
        /// Index set settled, residual above tolerance.
        Inexact = 1 => "inexact",
        /// Step cap reached; best iterate returned.
        MaxSteps = 2 => "max-steps",
        /// No rows.
        Empty = 3 => "empty",
        /// A non-finite value appeared; best finite iterate returned.
        NonFinite = 4 => "non-finite",
        /// The step's time budget was spent; best safe iterate returned.
        Budget = 5 => "budget",
    }
}

coded_enum! {
    /// What an actuator value means.
    ActuatorMode {
        /// Target velocity: rad/s (revolute, drum) or m/s (prismatic).
        #[default]
        Velocity = 0 => "velocity",
        /// Target position: rad or m.
        Position = 1 => "position",
        /// Force or torque: N or N·m.
        Effort = 2 => "effort",
    }
}

coded_enum! {
    /// Why the server rejected an input; index of the counter in
    /// [`InputHealth::rejected`](crate::InputHealth::rejected).
    RejectReason {
        /// Truncated, trailing bytes, bad magic, payload layout, reserved bytes, bad JSON.
        #[default]
        Malformed = 0 => "malformed",
        /// Unsupported version, unknown kind, or a kind that does not belong on the key.
        Version = 1 => "version",
        /// NaN or ±Inf.
        NonFinite = 2 => "non-finite",
        /// A value or code outside its range (joystick axis, mode, counts, name characters).
        OutOfRange = 3 => "out-of-range",
        /// An actuator the scene does not have, or of the wrong kind.
        UnknownActuator = 4 => "unknown-actuator",
        /// Too large: payload, number of entries, name length.
        Oversize = 5 => "oversize",
        /// Sequence not newer than the last accepted input of the same source.
        Stale = 6 => "stale",
        /// Anything else (server policy): a full server inbox, a joystick frame the mapping could
        /// not apply, a put refused by the server's Zenoh access control.
        Other = 7 => "other",
        /// An actuator command whose `mode` is not the scene actuator's mode.
        WrongMode = 8 => "wrong-mode",
    }
}

/// Number of [`RejectReason`] counters in a stats frame.
pub const REJECT_REASONS: usize = 9;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SOLVER_VARIANTS;

    #[test]
    fn variant_codes_are_indices_of_solver_variants() {
        assert_eq!(SolverVariant::ALL.len(), SOLVER_VARIANTS.len());
        for (i, name) in SOLVER_VARIANTS.iter().enumerate() {
            let v = SolverVariant::from_name(name).unwrap();
            assert_eq!(v.code() as usize, i);
            assert_eq!(v.name(), *name);
        }
        assert_eq!(SolverVariant::from_name("Skyline"), None);
        assert_eq!(SolverVariant::from_code(7), None);
    }

    #[test]
    fn reject_reasons_fill_the_counter_array() {
        assert_eq!(RejectReason::ALL.len(), REJECT_REASONS);
        for (i, r) in RejectReason::ALL.iter().enumerate() {
            assert_eq!(r.code() as usize, i);
        }
    }

    #[test]
    fn names_serialize_as_json_strings() {
        let s = serde_json::to_string(&SolverVariant::SkylineRefactor).unwrap();
        assert_eq!(s, "\"skyline-refactor\"");
        let v: ActuatorMode = serde_json::from_str("\"effort\"").unwrap();
        assert_eq!(v, ActuatorMode::Effort);
        assert!(serde_json::from_str::<ActuatorMode>("\"torque\"").is_err());
    }
}
