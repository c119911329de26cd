//! What a sensor measures: its kind with resolved ids and body sets, and the channels it fills
//! (names `{sensor}/{channel}`, in a fixed order the wire keeps).

use crate::dynamics::{BodyId, JointId};

/// A set of bodies (a machine, a load, the outrigger pads), as a membership mask over the world's
/// bodies, built once.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BodySet {
    mask: Vec<bool>,
}

impl BodySet {
    /// The set of `ids` in a world of `bodies` bodies.
    pub fn new(bodies: usize, ids: &[BodyId]) -> Self {
        let mut mask = vec![false; bodies];
        for id in ids {
            if let Some(m) = mask.get_mut(id.index()) {
                *m = true;
            }
        }
        BodySet { mask }
    }
    /// Whether `id` is in the set.
    #[inline]
    pub fn contains(&self, id: BodyId) -> bool {
        self.mask.get(id.index()).copied().unwrap_or(false)
    }
    /// The members, in id order.
    pub fn members(&self) -> impl Iterator<Item = BodyId> + '_ {
        self.mask.iter().enumerate().filter(|(_, m)| **m).map(|(i, _)| BodyId(i as u32))
    }
}

/// What a sensor measures (module doc of `signals` for the maths).
#[derive(Debug, Clone, PartialEq)]
pub enum SensorKind {
    /// A joint's reaction on its body A at the anchor, in A's joint frame: `fx fy fz tx ty tz`.
    Joint {
        /// The joint.
        joint: JointId,
    },
    /// A prismatic (or cylindrical) joint's force along its axis: `force`.
    Cylinder {
        /// The joint.
        joint: JointId,
    },
    /// The force magnitude `|F_A|` a joint carries (a rope's tension at a ball joint): `tension`.
    Tension {
        /// The joint.
        joint: JointId,
    },
    /// A hinge's torque about its axis (a winch drum): `torque`.
    Drum {
        /// The joint.
        joint: JointId,
    },
    /// A cable's tension at each of its joints from the top to the hook: `0 … n`, then `hook`
    /// (the last) and `max`.
    Cable {
        /// Its ball joints, top first.
        joints: Vec<JointId>,
    },
    /// Contact force sum between two body sets: `fx fy fz` (on `bodies`, world frame), `normal`,
    /// `friction`, `points` (pressed points), `stick`, `slip` (points in each state), `sliding`
    /// (1 when every pressed point slips: the contact as a whole slides; a rigid body on
    /// redundant contacts cannot slide while one of them sticks, whichever points the solver put
    /// at their bound), `slip_speed` (m/s: the largest relative tangential speed of the two
    /// bodies at a pressed point after the step — what an operator sees of a load moving on its
    /// support, where the index states only say which friction rows reached their bound).
    ContactSum {
        /// The bodies measured.
        bodies: BodySet,
        /// What they touch (`None`: any body not in `bodies`).
        with: Option<BodySet>,
    },
    /// The tipping margin of a machine: `distance` (m), `percent`, `supports` (polygon vertices),
    /// `stabilizing`, `overturning` (N m).
    Tipping {
        /// The machine's bodies, load included.
        bodies: BodySet,
        /// A contact closer than this (m) counts as support even when it carries no load.
        touch: f64,
    },
    /// Per-contact states (stick / slip / open) of every point touching `bodies`: no channels,
    /// the contact records of the signals frame.
    Contacts {
        /// The bodies watched.
        bodies: BodySet,
    },
}

const JOINT: &[&str] = &["fx", "fy", "fz", "tx", "ty", "tz"];
const CYLINDER: &[&str] = &["force"];
const DRUM: &[&str] = &["torque"];
const TENSION: &[&str] = &["tension"];
const CONTACT_SUM: &[&str] =
    &["fx", "fy", "fz", "normal", "friction", "points", "stick", "slip", "sliding", "slip_speed"];
const TIPPING: &[&str] = &["distance", "percent", "supports", "stabilizing", "overturning"];

impl SensorKind {
    /// Number of channels.
    pub fn channels(&self) -> usize {
        match self {
            SensorKind::Cable { joints } => joints.len() + 2,
            SensorKind::Contacts { .. } => 0,
            k => k.fixed_names().len(),
        }
    }

    fn fixed_names(&self) -> &'static [&'static str] {
        match self {
            SensorKind::Joint { .. } => JOINT,
            SensorKind::Cylinder { .. } => CYLINDER,
            SensorKind::Drum { .. } => DRUM,
            SensorKind::Tension { .. } => TENSION,
            SensorKind::ContactSum { .. } => CONTACT_SUM,
            SensorKind::Tipping { .. } => TIPPING,
            SensorKind::Cable { .. } | SensorKind::Contacts { .. } => &[],
        }
    }

    /// The name of channel `k` (without the sensor's name).
    pub fn channel_name(&self, k: usize) -> String {
        match self {
            SensorKind::Cable { joints } if k < joints.len() => k.to_string(),
            SensorKind::Cable { joints } if k == joints.len() => "hook".into(),
            SensorKind::Cable { .. } => "max".into(),
            kind => kind.fixed_names().get(k).copied().unwrap_or("").to_string(),
        }
    }

    /// The joints whose wrenches this sensor reads.
    pub fn joints(&self) -> &[JointId] {
        match self {
            SensorKind::Joint { joint }
            | SensorKind::Cylinder { joint }
            | SensorKind::Drum { joint }
            | SensorKind::Tension { joint } => std::slice::from_ref(joint),
            SensorKind::Cable { joints } => joints,
            _ => &[],
        }
    }
}

/// A named sensor and where its channels sit in [`Signals`](super::Signals).
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Name (channel names are `{name}/{channel}`).
    pub name: String,
    /// What it measures.
    pub kind: SensorKind,
}
