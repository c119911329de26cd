//! Solver variants and orderings, selectable by name at run time (CLI, wire, report).

use std::fmt;
use std::str::FromStr;

/// How a pivot step obtains the factor of `A_FF` (paper Alg. 1, 2, 3 and our extensions).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Variant {
    /// Alg. 1: dense Cholesky of the gathered `A_FF` at every pivot step.
    Full,
    /// Alg. 2: dense `L₀ = chol(A)` once, then per step copy + row/column deletions (dense).
    Downdate,
    /// Alg. 2 + 3: Cuthill–McKee, envelope storage, deletions from `L₀` restricted to the skyline
    /// (from the last step's factor when the tight set only grew).
    #[default]
    Skyline,
    /// Envelope refactor of the masked `A` (tight rows → identity) at every pivot step.
    SkylineRefactor,
    /// Keeps the previous step's envelope factor and refactors from the first changed row.
    Incremental,
    /// Per pivot step, the cheapest predicted of: deletions from `L₀`, further deletions from the
    /// previous factor, incremental refactor.
    Auto,
    /// Projected Gauss–Seidel (iterative baseline; not exact).
    Pgs,
}

impl Variant {
    /// Every variant, in report order.
    pub const ALL: [Variant; 7] = [
        Variant::Full,
        Variant::Downdate,
        Variant::Skyline,
        Variant::SkylineRefactor,
        Variant::Incremental,
        Variant::Auto,
        Variant::Pgs,
    ];

    /// The exact (pivoting) variants.
    pub const EXACT: [Variant; 6] = [
        Variant::Full,
        Variant::Downdate,
        Variant::Skyline,
        Variant::SkylineRefactor,
        Variant::Incremental,
        Variant::Auto,
    ];

    /// Name used on the CLI, on the wire and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Variant::Full => "full",
            Variant::Downdate => "downdate",
            Variant::Skyline => "skyline",
            Variant::SkylineRefactor => "skyline-refactor",
            Variant::Incremental => "incremental",
            Variant::Auto => "auto",
            Variant::Pgs => "pgs",
        }
    }

    /// Whether the variant is a direct (pivoting) method.
    pub fn is_exact(self) -> bool {
        self != Variant::Pgs
    }

    /// Whether the variant works on the envelope (and therefore reorders).
    pub fn uses_envelope(self) -> bool {
        matches!(self, Variant::Skyline | Variant::SkylineRefactor | Variant::Incremental | Variant::Auto)
    }
}

impl fmt::Display for Variant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A variant name that is not known.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown solver variant '{0}' (known: full, downdate, skyline, skyline-refactor, incremental, auto, pgs)"
)]
pub struct UnknownVariant(pub String);

impl FromStr for Variant {
    type Err = UnknownVariant;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Variant::ALL.into_iter().find(|v| v.name() == s).ok_or_else(|| UnknownVariant(s.to_string()))
    }
}

/// Symmetric reordering applied before an envelope factorization (paper §3.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OrderingKind {
    /// Keep the input order.
    Natural,
    /// Cuthill–McKee (the paper's choice).
    CuthillMcKee,
    /// Reverse Cuthill–McKee: same bandwidth, usually a smaller envelope.
    #[default]
    ReverseCuthillMcKee,
}

impl OrderingKind {
    /// Name used on the CLI and in reports.
    pub fn name(self) -> &'static str {
        match self {
            OrderingKind::Natural => "natural",
            OrderingKind::CuthillMcKee => "cm",
            OrderingKind::ReverseCuthillMcKee => "rcm",
        }
    }
}

impl FromStr for OrderingKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "natural" => Ok(OrderingKind::Natural),
            "cm" => Ok(OrderingKind::CuthillMcKee),
            "rcm" => Ok(OrderingKind::ReverseCuthillMcKee),
            _ => Err(format!("unknown ordering '{s}' (known: natural, cm, rcm)")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for v in Variant::ALL {
            assert_eq!(v.name().parse::<Variant>().unwrap(), v);
        }
        assert!("dantzig".parse::<Variant>().is_err());
        for o in [OrderingKind::Natural, OrderingKind::CuthillMcKee, OrderingKind::ReverseCuthillMcKee] {
            assert_eq!(o.name().parse::<OrderingKind>().unwrap(), o);
        }
    }
}
