//! [`Signals`]: every sensor of a scene evaluated after each step into channels sized at build,
//! the contact records of the `contacts` sensors, the threshold events and the faults' state.

use nalgebra::Vector3;

use super::event::{Event, Threshold};
use super::sensor::{BodySet, Sensor, SensorKind};
use super::support::SupportPolygon;
use crate::dynamics::{BodyId, ContactReport, JointId, World};
use crate::solver::IndexState;

/// Stick, slip or open (module doc of `signals`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ContactStateKind {
    /// The normal row is at its lower bound: no force.
    #[default]
    Open,
    /// Pressed, friction inside its bound.
    Stick,
    /// Pressed, a friction row at its bound `±μ λ_n`.
    Slip,
}

impl ContactStateKind {
    /// Classifies a point from its final index states and impulses.
    pub fn of(c: &ContactReport) -> Self {
        if c.normal_impulse <= 0.0 || c.states[0] == IndexState::Lower {
            return ContactStateKind::Open;
        }
        let bound = c.mu * c.normal_impulse;
        let at_bound =
            |k: usize| c.states[1 + k].is_tight() || c.friction_impulse[k].abs() >= bound * (1.0 - 1e-9);
        if at_bound(0) || at_bound(1) { ContactStateKind::Slip } else { ContactStateKind::Stick }
    }
}

/// One contact point of a `contacts` sensor in the last step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactState {
    /// Index of the sensor that reports it.
    pub sensor: u32,
    /// Collider A and collider B (the normal points from A to B).
    pub colliders: [u32; 2],
    /// Their bodies.
    pub bodies: [BodyId; 2],
    /// The point on A (world, m).
    pub point: Vector3<f64>,
    /// Its state.
    pub state: ContactStateKind,
    /// Normal force `λ_n / h` (N, ≥ 0).
    pub normal_force: f64,
    /// Friction force `|(λ₁, λ₂)| / h` (N, ≥ 0).
    pub friction_force: f64,
    /// Unit normal from A to B (world).
    pub normal: Vector3<f64>,
    /// Friction force on B, `(λ₁ t₁ + λ₂ t₂) / h` (world, N).
    pub friction: Vector3<f64>,
}

/// A scene's sensors, events and faults with their preallocated buffers (module doc of `signals`).
#[derive(Debug, Clone)]
pub struct Signals {
    pub(super) sensors: Vec<Sensor>,
    /// First channel of each sensor.
    pub(super) first: Vec<usize>,
    pub(super) names: Vec<String>,
    pub(super) values: Vec<f64>,
    pub(super) valid: Vec<bool>,
    /// Per sensor: dropped out (a fault).
    pub(super) dropout: Vec<bool>,
    /// Per joint: its slot in `wrench` (`u32::MAX`: not read).
    joint_slot: Vec<u32>,
    /// Per read joint: force on A and torque about A's centre of mass.
    wrench: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// Per sensor: the support polygon of a tipping sensor.
    polygons: Vec<Option<SupportPolygon>>,
    pub(super) contacts: Vec<ContactState>,
    pub(super) thresholds: Vec<Threshold>,
    /// Events of the last step.
    pub(super) fired: Vec<Event>,
    /// Events between steps (refused fault requests), reported with the next step's.
    pub(super) queued: Vec<Event>,
    /// Events since the scene was (re)loaded.
    pub(super) events_total: u64,
    /// Faults applied / refused since the scene was (re)loaded.
    pub(super) faults_applied: u64,
    pub(super) faults_rejected: u64,
}

/// Contact points a `contacts` sensor keeps per step at most before the frame would grow too
/// large; further points are not reported (the sums still count them).
pub const MAX_CONTACT_RECORDS: usize = 4096;

/// Events kept between two steps (refused fault requests) at most; more are counted, not listed.
pub const MAX_QUEUED_EVENTS: usize = 64;

impl Default for Signals {
    fn default() -> Self {
        Signals::new(Vec::new(), 0, 0, Vector3::new(0.0, 0.0, -9.81))
    }
}

impl Signals {
    /// Signals of `sensors` in a world of `joints` joints and `bodies` bodies under gravity `g`,
    /// every buffer sized here.
    pub fn new(sensors: Vec<Sensor>, joints: usize, bodies: usize, g: Vector3<f64>) -> Self {
        let mut first = Vec::with_capacity(sensors.len());
        let mut names = Vec::new();
        let mut joint_slot = vec![u32::MAX; joints];
        let mut n_read = 0u32;
        let mut polygons = Vec::with_capacity(sensors.len());
        let mut contacts_cap = 0;
        for s in &sensors {
            first.push(names.len());
            for k in 0..s.kind.channels() {
                names.push(format!("{}/{}", s.name, s.kind.channel_name(k)));
            }
            for j in s.kind.joints() {
                if let Some(slot) = joint_slot.get_mut(j.index())
                    && *slot == u32::MAX
                {
                    *slot = n_read;
                    n_read += 1;
                }
            }
            polygons.push(match &s.kind {
                SensorKind::Tipping { .. } => Some(SupportPolygon::new(g, 8 * bodies.max(16))),
                _ => None,
            });
            if let SensorKind::Contacts { .. } = s.kind {
                contacts_cap = MAX_CONTACT_RECORDS;
            }
        }
        let n = names.len();
        let count = sensors.len();
        Signals {
            sensors,
            first,
            names,
            values: vec![0.0; n],
            valid: vec![true; n],
            dropout: vec![false; count],
            joint_slot,
            wrench: vec![(Vector3::zeros(), Vector3::zeros()); n_read as usize],
            polygons,
            contacts: Vec::with_capacity(contacts_cap),
            thresholds: Vec::new(),
            fired: Vec::new(),
            queued: Vec::with_capacity(MAX_QUEUED_EVENTS),
            events_total: 0,
            faults_applied: 0,
            faults_rejected: 0,
        }
    }

    /// Makes sure the joint `j` is read every step (a fault that watches its tension).
    pub fn watch_joint(&mut self, j: JointId) {
        if let Some(slot) = self.joint_slot.get_mut(j.index())
            && *slot == u32::MAX
        {
            *slot = self.wrench.len() as u32;
            self.wrench.push((Vector3::zeros(), Vector3::zeros()));
        }
    }

    /// The sensors.
    pub fn sensors(&self) -> &[Sensor] {
        &self.sensors
    }
    /// Channel names, `{sensor}/{channel}`.
    pub fn channel_names(&self) -> &[String] {
        &self.names
    }
    /// Channel values of the last step (0 for a dropped-out channel).
    pub fn values(&self) -> &[f64] {
        &self.values
    }
    /// Whether each channel holds a reading (false: its sensor dropped out).
    pub fn valid(&self) -> &[bool] {
        &self.valid
    }
    /// A channel's index by name.
    pub fn channel(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }
    /// A channel's value by name.
    pub fn value(&self, name: &str) -> Option<f64> {
        self.channel(name).map(|i| self.values[i])
    }
    /// The channels of sensor `name` (`None`: no such sensor).
    pub fn sensor_values(&self, name: &str) -> Option<&[f64]> {
        let i = self.sensors.iter().position(|s| s.name == name)?;
        let n = self.sensors[i].kind.channels();
        Some(&self.values[self.first[i]..self.first[i] + n])
    }
    /// A sensor's index by name.
    pub fn sensor_index(&self, name: &str) -> Option<usize> {
        self.sensors.iter().position(|s| s.name == name)
    }
    /// Contact records of the last step (`contacts` sensors).
    pub fn contacts(&self) -> &[ContactState] {
        &self.contacts
    }
    /// Events of the last step.
    pub fn events(&self) -> &[Event] {
        &self.fired
    }
    /// Events since the scene was (re)loaded.
    pub fn events_total(&self) -> u64 {
        self.events_total
    }
    /// Faults applied since the scene was (re)loaded.
    pub fn faults_applied(&self) -> u64 {
        self.faults_applied
    }
    /// Fault requests refused since the scene was (re)loaded.
    pub fn faults_rejected(&self) -> u64 {
        self.faults_rejected
    }
    /// Sets a sensor's dropout (a fault): its channels read 0 and are flagged invalid.
    pub fn set_dropout(&mut self, sensor: usize, on: bool) -> bool {
        match self.dropout.get_mut(sensor) {
            Some(d) => {
                *d = on;
                true
            }
            None => false,
        }
    }
    /// The force magnitude `|F_A|` a joint carried in the last step (N), if it is read.
    pub fn joint_force(&self, j: JointId) -> Option<f64> {
        self.wrench(j).map(|w| w.0.norm())
    }
    /// The threshold declarations.
    pub fn thresholds(&self) -> &[Threshold] {
        &self.thresholds
    }

    /// The wrench (force on A, torque about A's centre of mass) a read joint applied in the last
    /// step.
    pub(super) fn wrench(&self, j: JointId) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let slot = *self.joint_slot.get(j.index())?;
        self.wrench.get(slot as usize).copied()
    }

    /// Evaluates every sensor on the world's last step. No allocation.
    pub fn evaluate(&mut self, world: &World) {
        self.sum_joint_wrenches(world);
        self.contacts.clear();
        let h = world.settings().timestep;
        for s in 0..self.sensors.len() {
            let (first, n) = (self.first[s], self.sensors[s].kind.channels());
            if self.dropout[s] {
                self.values[first..first + n].fill(0.0);
                self.valid[first..first + n].fill(false);
                continue;
            }
            self.valid[first..first + n].fill(true);
            let mut out = [0.0; OUT];
            match &self.sensors[s].kind {
                SensorKind::Joint { joint } => {
                    let (f, t) = self.joint_frame_wrench(world, *joint);
                    out[..3].copy_from_slice(f.as_slice());
                    out[3..6].copy_from_slice(t.as_slice());
                }
                SensorKind::Cylinder { joint } => out[0] = self.joint_frame_wrench(world, *joint).0.x,
                SensorKind::Drum { joint } => out[0] = self.joint_frame_wrench(world, *joint).1.x,
                SensorKind::Tension { joint } => out[0] = self.wrench(*joint).map_or(0.0, |w| w.0.norm()),
                SensorKind::Cable { joints } => {
                    let mut max: f64 = 0.0;
                    for (k, j) in joints.iter().enumerate() {
                        let t = self.wrench(*j).map_or(0.0, |w| w.0.norm());
                        self.values[first + k] = t;
                        max = max.max(t);
                    }
                    let m = joints.len();
                    self.values[first + m] = if m > 0 { self.values[first + m - 1] } else { 0.0 };
                    self.values[first + m + 1] = max;
                    continue;
                }
                SensorKind::ContactSum { bodies, with } => {
                    contact_sum(world, bodies, with.as_ref(), h, &mut out);
                }
                SensorKind::Tipping { bodies, touch } => {
                    let poly = self.polygons[s].as_mut().expect("a tipping sensor has its polygon");
                    tipping(world, bodies, *touch, poly, &mut out);
                }
                SensorKind::Contacts { bodies } => {
                    for c in world.contacts() {
                        if self.contacts.len() < MAX_CONTACT_RECORDS
                            && (bodies.contains(c.bodies[0]) || bodies.contains(c.bodies[1]))
                        {
                            self.contacts.push(ContactState {
                                sensor: s as u32,
                                colliders: [c.collider_a.0, c.collider_b.0],
                                bodies: c.bodies,
                                point: c.point_a,
                                state: ContactStateKind::of(&c),
                                normal_force: c.normal_impulse.max(0.0) / h,
                                friction_force: friction_norm(&c) / h,
                                normal: c.normal,
                                friction: (c.tangents[0] * c.friction_impulse[0]
                                    + c.tangents[1] * c.friction_impulse[1])
                                    / h,
                            });
                        }
                    }
                }
            }
            self.values[first..first + n].copy_from_slice(&out[..n]);
        }
    }

    /// One pass over the last step's joint rows: the wrench on A of every joint a sensor or fault
    /// reads.
    fn sum_joint_wrenches(&mut self, world: &World) {
        self.wrench.fill((Vector3::zeros(), Vector3::zeros()));
        if self.wrench.is_empty() {
            return;
        }
        let h = world.settings().timestep;
        for (joint, row, lambda, _) in world.last_joint_rows() {
            let Some(&slot) = self.joint_slot.get(joint.index()) else { continue };
            if slot == u32::MAX {
                continue;
            }
            // Block 0 of a joint row is body A's (`ConstraintRow::pair`).
            let w = &mut self.wrench[slot as usize];
            w.0 += row.jac[0].lin * (lambda / h);
            w.1 += row.jac[0].ang * (lambda / h);
        }
    }

    /// A joint's wrench on A at its anchor, in A's joint frame (module doc).
    fn joint_frame_wrench(&self, world: &World, j: JointId) -> (Vector3<f64>, Vector3<f64>) {
        let (Some((f, tau)), Some(joint)) = (self.wrench(j), world.joint(j)) else {
            return (Vector3::zeros(), Vector3::zeros());
        };
        let Some(a) = world.body(joint.body_a()) else { return (Vector3::zeros(), Vector3::zeros()) };
        let pose = a.pose();
        let frame = pose * joint.frame_a();
        let p = frame.translation.vector;
        let t = tau + (a.position() - p).cross(&f);
        (frame.rotation.inverse_transform_vector(&f), frame.rotation.inverse_transform_vector(&t))
    }
}

fn friction_norm(c: &ContactReport) -> f64 {
    c.friction_impulse[0].hypot(c.friction_impulse[1])
}

/// Channels of the widest sensor kind (`contact_sum`).
const OUT: usize = 10;

/// The relative tangential speed of a contact's two bodies at its points (m/s): how fast B's point
/// slides over A's, from the bodies' velocities after the step.
fn slip_speed(world: &World, c: &ContactReport) -> f64 {
    let at = |k: usize, p: &Vector3<f64>| {
        world
            .body(c.bodies[k])
            .map_or(Vector3::zeros(), |b| b.linvel() + b.angvel().cross(&(p - b.position())))
    };
    let v = at(1, &c.point_b) - at(0, &c.point_a);
    (v - c.normal * c.normal.dot(&v)).norm()
}

/// The force on `bodies` from `with` (or from everything else) and its magnitudes and states:
/// `fx fy fz normal friction points stick slip sliding slip_speed`.
fn contact_sum(world: &World, bodies: &BodySet, with: Option<&BodySet>, h: f64, out: &mut [f64; OUT]) {
    let other = |b| with.map_or(!bodies.contains(b), |w| w.contains(b));
    let mut f = Vector3::zeros();
    for c in world.contacts() {
        let [a, b] = c.bodies;
        let sign = if bodies.contains(b) && other(a) {
            1.0
        } else if bodies.contains(a) && other(b) {
            -1.0
        } else {
            continue;
        };
        let on_b = c.normal * c.normal_impulse
            + c.tangents[0] * c.friction_impulse[0]
            + c.tangents[1] * c.friction_impulse[1];
        f += on_b * (sign / h);
        out[3] += c.normal_impulse.max(0.0) / h;
        out[4] += friction_norm(&c) / h;
        match ContactStateKind::of(&c) {
            ContactStateKind::Open => {}
            ContactStateKind::Stick => {
                out[5] += 1.0;
                out[6] += 1.0;
            }
            ContactStateKind::Slip => {
                out[5] += 1.0;
                out[7] += 1.0;
            }
        }
        if ContactStateKind::of(&c) != ContactStateKind::Open {
            out[9] = out[9].max(slip_speed(world, &c));
        }
    }
    out[..3].copy_from_slice(f.as_slice());
    out[8] = if out[5] > 0.0 && out[7] == out[5] { 1.0 } else { 0.0 };
}

/// The tipping margin of the machine `bodies`: `distance percent supports stabilizing overturning`.
fn tipping(world: &World, bodies: &BodySet, touch: f64, poly: &mut SupportPolygon, out: &mut [f64; OUT]) {
    poly.clear();
    for c in world.contacts() {
        let [a, b] = c.bodies;
        let point = match (bodies.contains(a), bodies.contains(b)) {
            (true, false) => c.point_a,
            (false, true) => c.point_b,
            _ => continue,
        };
        if c.normal_impulse > 0.0 || c.gap <= touch {
            poly.push(&point);
        }
    }
    let (mut m, mut mx) = (0.0, Vector3::zeros());
    for id in bodies.members() {
        if let Some(b) = world.body(id).filter(|b| b.is_dynamic()) {
            m += b.mass();
            mx += b.position() * b.mass();
        }
    }
    let com = if m > 0.0 { mx / m } else { mx };
    let g = world.settings().gravity.norm();
    let members = bodies
        .members()
        .filter_map(|id| world.body(id).filter(|b| b.is_dynamic()).map(|b| (b.mass(), b.position())));
    let t = poly.margin(&com, g, members);
    out[..5].copy_from_slice(&[t.distance, t.percent, t.supports as f64, t.stabilizing, t.overturning]);
    out[5..].fill(0.0);
}
