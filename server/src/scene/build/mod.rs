//! From a parsed scene file to a [`World`] with its controls: repeats expanded, references
//! resolved, every number checked finite and in range, each error located at its table.
//!
//! One file per stage of [`build`]:
//!
//! | file | stage |
//! |---|---|
//! | `mod.rs` | the builder, its checked readers of numbers, vectors, rotations and body names; [`build`] |
//! | `settings.rs` | `[scene]`: world settings, the watchdog's bounds, scene-wide defaults; `[[material]]` |
//! | `bodies.rs` | `[[body]]` and its shapes, inertia from shapes |
//! | `joints.rs` | `[[joint]]`, `[[spring]]`, `[[coupling]]` |
//! | `items.rs` | the items in build order, `[[repeat]]` instances, `[[cable]]`, `[[buoyancy]]` |
//! | `actuators.rs` | `[[actuator]]`, `[joystick]`, `[[script]]` |

use std::collections::{HashMap, HashSet};
use std::ops::Range;

use nalgebra::{Isometry3, Matrix3, Quaternion, SymmetricEigen, Translation3, UnitQuaternion, Vector3};
use toml::Spanned;

use super::checks::{R, Source};
use super::controls::{
    Actuator, ActuatorFault, ActuatorKind, ActuatorTarget, AxisMode, ButtonAction, Controls, JoyAxis,
    JoyButton, JoystickMap, Neutral, RampProfile, SceneEvent, Script, ScriptEntry,
};
use super::format::*;
use super::{Scene, SceneError};
use crate::dynamics::{
    BodyBuilder, BodyId, Buoyancy, ChainBuilder, ChainEnd, ChainShape, ColliderBuilder, CollisionGroups,
    CouplingBuilder, CouplingId, ForceElement, FreeAxis, GeometricStiffness, JointBuilder, JointFrames,
    JointId, JointKind, JointLimit, JointMotor, Material, ModelError, Shape, SpringDamper, WatchdogSettings,
    Water, Wave, World, WorldSettings, box_inertia, capsule_inertia, cylinder_inertia, sphere_inertia,
};

mod actuators;
mod bodies;
mod items;
mod joints;
mod settings;

use actuators::{actuators, joystick, script};

/// Builder state: the world so far and name tables.
pub(super) struct Builder<'a> {
    src: &'a Source<'a>,
    world: World,
    default_mu: f64,
    default_compliance: f64,
    body_spans: HashMap<String, Range<usize>>,
    /// Display-only shapes ([`Scene::visuals`]).
    visuals: Vec<(BodyId, Shape, Isometry3<f64>)>,
}

/// A built shape: the shape, its pose in the body frame, its friction and its material name.
type ShapeParts = (Shape, Isometry3<f64>, Option<f64>, Option<String>);

impl Builder<'_> {
    pub(super) fn invalid(&self, span: &Range<usize>, field: &str, message: impl Into<String>) -> SceneError {
        self.src.invalid(span, field, message)
    }

    fn model(&self, span: &Range<usize>, item: &str, e: impl Into<ModelError>) -> SceneError {
        self.src.model(span, item, e)
    }

    pub(super) fn finite(&self, span: &Range<usize>, field: &str, v: f64) -> R<f64> {
        self.src.finite(span, field, v)
    }

    pub(super) fn positive(&self, span: &Range<usize>, field: &str, v: f64) -> R<f64> {
        self.src.positive(span, field, v)
    }

    fn non_negative(&self, span: &Range<usize>, field: &str, v: f64) -> R<f64> {
        self.src.non_negative(span, field, v)
    }

    pub(super) fn vec3(&self, span: &Range<usize>, field: &str, v: [f64; 3]) -> R<Vector3<f64>> {
        self.src.vec3(span, field, v)
    }

    fn unit3(&self, span: &Range<usize>, field: &str, v: [f64; 3]) -> R<Vector3<f64>> {
        self.src.unit3(span, field, v)
    }

    /// `rotation` (roll, pitch, yaw in degrees, `R = R_z(yaw) R_y(pitch) R_x(roll)`) or
    /// `quaternion` (w, x, y, z; normalized), identity when both are absent.
    fn rotation(
        &self,
        span: &Range<usize>,
        rpy: Option<[f64; 3]>,
        quat: Option<[f64; 4]>,
    ) -> R<UnitQuaternion<f64>> {
        match (rpy, quat) {
            (Some(_), Some(_)) => {
                Err(self.invalid(span, "rotation", "give `rotation` or `quaternion`, not both"))
            }
            (Some(r), None) => {
                let r = self.vec3(span, "rotation", r)?.map(f64::to_radians);
                Ok(UnitQuaternion::from_euler_angles(r.x, r.y, r.z))
            }
            (None, Some(q)) => {
                for c in q {
                    self.finite(span, "quaternion", c)?;
                }
                let q = Quaternion::new(q[0], q[1], q[2], q[3]);
                if q.norm() < 1e-9 {
                    return Err(self.invalid(span, "quaternion", "the quaternion is zero"));
                }
                Ok(UnitQuaternion::from_quaternion(q))
            }
            (None, None) => Ok(UnitQuaternion::identity()),
        }
    }

    fn body(&self, span: &Range<usize>, field: &str, name: &str) -> R<BodyId> {
        self.world.body_id(name).ok_or_else(|| self.invalid(span, field, format!("no body named `{name}`")))
    }

    fn opt_body(&self, span: &Range<usize>, field: &str, name: Option<&str>) -> R<Option<BodyId>> {
        match name {
            None | Some("world") => Ok(None),
            Some(n) => self.body(span, field, n).map(Some),
        }
    }
}

/// Parses and builds a scene; `file` labels error locations. Every stage checks what it reads, in
/// the order of the file's sections, so the first error met is the one reported.
pub(crate) fn build(file: &str, text: &str) -> R<Scene> {
    let src = Source::new(file, text);
    let parsed: SceneFile = toml::from_str(text).map_err(|e| SceneError::Syntax {
        at: src.at(e.span().unwrap_or(0..0)),
        message: e.message().to_string(),
    })?;
    let sspan = parsed.scene.span();
    let sec = parsed.scene.get_ref();
    let mut b = Builder::new(&src);
    let settings = b.world_settings(&sspan, sec)?;
    let watchdog = b.watchdog_settings(&sspan, sec)?;
    let duration = b.positive(&sspan, "duration", sec.duration.unwrap_or(20.0))?;
    if sec.name.trim().is_empty() {
        return Err(b.invalid(&sspan, "name", "the scene needs a name"));
    }
    b.world.set_settings(settings).map_err(|e| b.model(&sspan, "scene", e))?;
    b.scene_defaults(&sspan, sec)?;
    for m in &parsed.material {
        b.add_material(&m.span(), m.get_ref())?;
    }
    b.add_items(&parsed)?;
    let controls = actuators(&b, &parsed.actuator)?;
    let joystick = match &parsed.joystick {
        Some(j) => joystick(&b, &controls, j.get_ref())?,
        None => JoystickMap::default(),
    };
    let script = script(&b, &controls, &parsed.script)?;
    let mut signals = super::signals::build_signals(&src, &b.world, &parsed.sensor, &parsed.event)?;
    let faults = super::signals::build_faults(&src, &b.world, &controls, &mut signals, &parsed.fault)?;
    let declared_faults = faults.list().len();
    let visuals = std::mem::take(&mut b.visuals);
    let mut world = b.world;
    let mut controls = controls;
    // The initial actuator values are in force from the first step on.
    controls.apply(&mut world, settings.timestep).map_err(|e| SceneError::Invalid {
        at: src.at(sspan.clone()),
        field: "actuator".into(),
        message: e.to_string(),
    })?;
    Ok(Scene {
        name: sec.name.clone(),
        description: sec.description.clone(),
        source: file.to_string(),
        text: text.to_string(),
        duration,
        world,
        controls,
        script,
        joystick,
        watchdog,
        signals,
        faults,
        declared_faults,
        visuals,
    })
}

/// The stages of [`build`]: the `[scene]` section, then the items in an order that lets the
/// tables come in any order in the file.
impl<'a> Builder<'a> {
    /// An empty world with default settings (the scene's replace them once checked) and defaults.
    fn new(src: &'a Source<'a>) -> Self {
        Builder {
            src,
            world: World::new(WorldSettings::default()).expect("default settings are valid"),
            default_mu: 1.0,
            default_compliance: crate::dynamics::DEFAULT_COMPLIANCE,
            body_spans: HashMap::new(),
            visuals: Vec::new(),
        }
    }
}
