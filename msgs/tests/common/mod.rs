//! Shared proptest strategies (valid messages of every kind, bounded sizes), sample frames and a
//! small seeded generator for the fuzz loops.
#![allow(dead_code)]

use pivotsim_msgs::*;
use proptest::prelude::*;

/// SplitMix64: a tiny seeded generator for bounded fuzz loops.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

pub fn finite() -> impl Strategy<Value = f64> {
    prop_oneof![-1e6..1e6f64, Just(0.0), Just(-0.0), Just(f64::MAX), Just(f64::MIN_POSITIVE)]
}

pub fn non_negative() -> impl Strategy<Value = f64> {
    prop_oneof![0.0..1e7f64, Just(0.0), Just(f64::MAX)]
}

pub fn vec3() -> impl Strategy<Value = [f64; 3]> {
    [finite(), finite(), finite()]
}

pub fn unit_quaternion() -> impl Strategy<Value = [f64; 4]> {
    [-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64].prop_map(|q| {
        let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        if n < 1e-3 { [0.0, 0.0, 0.0, 1.0] } else { q.map(|v| v / n) }
    })
}

pub fn body_pose() -> impl Strategy<Value = BodyPose> {
    let flags =
        prop::sample::select(vec![0, BODY_ASLEEP, BODY_KINEMATIC, BODY_STATIC, BODY_ASLEEP | BODY_STATIC]);
    (any::<u32>(), flags, vec3(), unit_quaternion(), vec3(), vec3()).prop_map(|(id, flags, p, q, v, w)| {
        BodyPose { id, flags, position: p, orientation: q, linear_velocity: v, angular_velocity: w }
    })
}

pub fn pose_frame() -> impl Strategy<Value = PoseFrame> {
    (any::<u64>(), non_negative(), any::<u64>(), prop::collection::vec(body_pose(), 0..24)).prop_map(
        |(sequence, sim_time, wall_time_ns, bodies)| PoseFrame { sequence, sim_time, wall_time_ns, bodies },
    )
}

pub fn island() -> impl Strategy<Value = IslandStats> {
    (
        prop::sample::select(SolverVariant::ALL.to_vec()),
        prop::sample::select(SolveStatus::ALL.to_vec()),
        any::<bool>(),
        0u32..2000,
        0.0..=1.0f64,
        any::<[u32; 3]>(),
        0.0..1e7f64,
        non_negative(),
    )
        .prop_map(
            |(
                variant,
                status,
                fallback,
                rows,
                frac,
                [bodies, pivot_steps, iterations],
                solve_us,
                residual_rel,
            )| {
                IslandStats {
                    variant,
                    status,
                    fallback,
                    rows,
                    bodies,
                    pivot_steps,
                    tight: (rows as f64 * frac) as u32,
                    iterations,
                    solve_us,
                    residual_rel,
                }
            },
        )
}

pub fn solver_stats() -> impl Strategy<Value = SolverStats> {
    (
        any::<u64>(),
        non_negative(),
        non_negative(),
        any::<u32>(),
        prop::collection::vec(island(), 0..12),
        any::<(u64, [u64; REJECT_REASONS], u32, bool)>(),
        any::<bool>(),
    )
        .prop_map(|(sequence, sim_time, step_wall_us, overruns, islands, inputs, sum)| {
            let mut totals = StepTotals::from_islands(&islands);
            if !sum {
                totals.pivot_steps = totals.pivot_steps.wrapping_mul(3);
            }
            let (accepted, rejected, deadman_trips, deadman_active) = inputs;
            SolverStats {
                sequence,
                sim_time,
                step_wall_us,
                overruns,
                totals,
                inputs: InputHealth { accepted, rejected, deadman_trips, deadman_active },
                islands,
                unstable: sequence % 2 == 1,
                unstable_steps: overruns as u16,
                degraded: DegradedSolves {
                    capped: overruns,
                    inexact: overruns / 3,
                    budget: deadman_trips,
                    fallback: overruns.rotate_left(7),
                },
            }
        })
}

pub fn actuator_name() -> impl Strategy<Value = ActuatorName> {
    "[A-Za-z0-9_./-]{1,32}".prop_map(|s| ActuatorName::new(&s).unwrap())
}

pub fn joystick() -> impl Strategy<Value = Joystick> {
    (any::<u64>(), any::<u32>(), prop::collection::vec(-1.0..=1.0f32, 0..=MAX_AXES), 0u8..=64, any::<u64>())
        .prop_map(|(seq, src, axes, nb, buttons)| {
            let mask = if nb == 64 { u64::MAX } else { (1u64 << nb) - 1 };
            Joystick::new(seq, src, &axes, buttons & mask, nb).unwrap()
        })
}

pub fn input() -> impl Strategy<Value = InputCommand> {
    let winch = (any::<u64>(), any::<u32>(), actuator_name(), finite()).prop_map(
        |(sequence, source_id, actuator, s)| {
            InputCommand::Winch(WinchCommand { sequence, source_id, actuator, drum_speed: s })
        },
    );
    let targets = prop::collection::btree_map("[A-Za-z0-9_./-]{1,32}", finite(), 0..=MAX_BOOM_TARGETS);
    let boom = (any::<u64>(), any::<u32>(), targets).prop_map(|(sequence, source_id, t)| {
        let targets =
            t.into_iter().map(|(n, value)| BoomTarget { actuator: ActuatorName::new(&n).unwrap(), value });
        InputCommand::Boom(BoomCommand { sequence, source_id, targets: targets.collect() })
    });
    let actuator = (
        any::<u64>(),
        any::<u32>(),
        prop::sample::select(ActuatorMode::ALL.to_vec()),
        actuator_name(),
        finite(),
    )
        .prop_map(|(sequence, source_id, mode, actuator, value)| {
            InputCommand::Actuator(ActuatorCommand { sequence, source_id, mode, actuator, value })
        });
    prop_oneof![joystick().prop_map(InputCommand::Joystick), winch, boom, actuator]
}

pub fn scene_ref() -> impl Strategy<Value = String> {
    "[^\\x00-\\x1f\\x7f]{1,40}"
}

/// A valid snapshot path: relative components that never start with a dot, so none is `..`
/// (which the encoder refuses; `malformed.rs` checks that refusal).
const SNAPSHOT_PATH: &str = "[A-Za-z0-9_-]{1,20}(/[A-Za-z0-9_-][A-Za-z0-9_.-]{0,19}){0,3}";

pub fn control_request() -> impl Strategy<Value = ControlRequest> {
    let command = prop_oneof![
        Just(ControlCommand::Pause),
        Just(ControlCommand::Resume),
        (1..=MAX_STEP_COUNT).prop_map(|count| ControlCommand::Step { count }),
        Just(ControlCommand::Reset),
        prop::sample::select(SolverVariant::ALL.to_vec())
            .prop_map(|variant| ControlCommand::SetVariant { variant }),
        scene_ref().prop_map(|scene| ControlCommand::LoadScene { scene }),
        (0.0..1e6f64).prop_map(|sim_time| ControlCommand::RunUntil { sim_time }),
        SNAPSHOT_PATH.prop_map(|path| ControlCommand::Snapshot { path }),
        SNAPSHOT_PATH.prop_map(|path| ControlCommand::Restore { path }),
        (
            prop::sample::select(FaultKind::ALL.to_vec()),
            "[A-Za-z0-9_./-]{1,64}",
            prop::option::of(1e-3..1e7f64),
            prop::option::of(0.0..=1.0f64),
            prop::option::of(0.0..100.0f64),
        )
            .prop_map(|(fault, target, tension, to, ramp)| ControlCommand::Fault {
                fault,
                target,
                tension,
                to,
                ramp
            }),
    ];
    (any::<u64>(), command).prop_map(|(id, command)| ControlRequest { id, command })
}

pub fn control_reply() -> impl Strategy<Value = ControlReply> {
    let status = (
        scene_ref(),
        any::<bool>(),
        any::<u64>(),
        non_negative(),
        prop::sample::select(SolverVariant::ALL.to_vec()),
        prop::option::of((any::<u32>(), any::<u32>(), any::<u32>(), non_negative())),
    )
        .prop_map(|(scene, paused, sequence, sim_time, variant, steps)| ServerStatus {
            scene,
            paused,
            sequence,
            sim_time,
            variant,
            steps: steps.map(|(count, island_solves, not_converged, max_residual_rel)| StepReport {
                count,
                island_solves,
                not_converged,
                max_residual_rel,
            }),
        });
    let codes = vec![
        ControlErrorCode::InvalidRequest,
        ControlErrorCode::UnknownVariant,
        ControlErrorCode::UnknownScene,
        ControlErrorCode::SceneLoadFailed,
        ControlErrorCode::LoadRefused,
        ControlErrorCode::Busy,
        ControlErrorCode::FaultRejected,
        ControlErrorCode::InThePast,
        ControlErrorCode::SnapshotFailed,
        ControlErrorCode::Internal,
    ];
    let outcome = prop_oneof![
        status.prop_map(ControlOutcome::Ok),
        (prop::sample::select(codes), ".{0,60}")
            .prop_map(|(code, message)| ControlOutcome::Error(ControlFailure { code, message })),
    ];
    (any::<u64>(), outcome).prop_map(|(id, outcome)| ControlReply { id, outcome })
}

pub fn positive() -> impl Strategy<Value = f64> {
    prop_oneof![1e-6..1e3f64, Just(f64::MIN_POSITIVE)]
}

pub fn shape() -> impl Strategy<Value = Shape> {
    let heights =
        prop_oneof![
            (2u32..6, 2u32..6).prop_flat_map(|(r, c)| {
                prop::collection::vec(finite(), (r * c) as usize)
                    .prop_map(move |h| (r, c, HeightData::Inline(h)))
            }),
            (2u32..=MAX_HEIGHTFIELD_DIM, 2u32..=MAX_HEIGHTFIELD_DIM, "[a-z/._-]{1,30}")
                .prop_map(|(r, c, u)| (r, c, HeightData::Reference(u))),
        ];
    let mesh = prop_oneof![
        (3usize..10).prop_flat_map(|n| {
            let tri = [0..n as u32, 0..n as u32, 0..n as u32];
            (prop::collection::vec(vec3(), n), prop::collection::vec(tri, 1..8))
                .prop_map(|(vertices, triangles)| MeshData::Inline { vertices, triangles })
        }),
        "[a-z/._-]{1,30}".prop_map(MeshData::Reference),
    ];
    prop_oneof![
        positive().prop_map(|radius| Shape::Ball { radius }),
        [positive(), positive(), positive()].prop_map(|half_extents| Shape::Box { half_extents }),
        (positive(), positive()).prop_map(|(radius, half_height)| Shape::Capsule { radius, half_height }),
        (positive(), positive()).prop_map(|(radius, half_height)| Shape::Cylinder { radius, half_height }),
        prop::collection::vec(vec3(), 4..12).prop_map(|vertices| Shape::ConvexHull { vertices }),
        (heights, [positive(), positive()]).prop_map(|((rows, cols, heights), extent)| Shape::Heightfield {
            rows,
            cols,
            extent,
            heights
        }),
        mesh.prop_map(|mesh| Shape::Trimesh { mesh }),
    ]
}

fn collider() -> impl Strategy<Value = Collider> {
    (shape(), vec3(), unit_quaternion()).prop_map(|(shape, position, orientation)| Collider {
        shape,
        position,
        orientation,
    })
}

fn body_parts() -> impl Strategy<Value = (BodyKind, f64, Vec<Collider>, String)> {
    (
        prop::sample::select(vec![BodyKind::Dynamic, BodyKind::Kinematic, BodyKind::Static]),
        positive(),
        prop::collection::vec(collider(), 0..3),
        "\\PC{1,12}",
    )
}

pub fn scene() -> impl Strategy<Value = SceneDescription> {
    (1usize..6)
        .prop_flat_map(|n| {
            (
                prop::collection::vec(body_parts(), n),
                prop::collection::vec((any::<prop::sample::Index>(), any::<bool>()), 0..n),
                prop::collection::vec(
                    (prop::sample::select(ActuatorMode::ALL.to_vec()), any::<bool>(), finite()),
                    0..4,
                ),
                prop::collection::vec((any::<bool>(), 0u8..32, any::<prop::sample::Index>(), finite()), 0..6),
                vec3(),
                positive(),
            )
        })
        .prop_map(|(bodies, joints, actuators, bindings, gravity, timestep)| {
            let bodies: Vec<BodyInfo> = bodies
                .into_iter()
                .enumerate()
                .map(|(i, (kind, mass, colliders, name))| BodyInfo {
                    id: 10 + 3 * i as u32,
                    name: format!("{i}-{name}"),
                    kind,
                    mass,
                    // Odd bodies draw their shapes once more as visuals (a rope segment's).
                    visuals: if i % 2 == 1 { colliders.clone() } else { Vec::new() },
                    colliders,
                })
                .collect();
            let kinds =
                [JointKind::Fixed, JointKind::Hinge, JointKind::Prismatic, JointKind::Ball, JointKind::Other];
            let joints: Vec<JointInfo> = joints
                .into_iter()
                .enumerate()
                .map(|(i, (parent, world))| JointInfo {
                    name: format!("joint{i}"),
                    kind: kinds[i % kinds.len()],
                    parent: if world || i == 0 { None } else { Some(bodies[parent.index(i)].id) },
                    child: bodies[i].id,
                    frame: (i % 2 == 0).then(|| JointFrame {
                        body: Some(bodies[i].id),
                        position: [0.5, -0.25, 1.0],
                        orientation: [
                            0.0,
                            0.0,
                            std::f64::consts::FRAC_1_SQRT_2,
                            std::f64::consts::FRAC_1_SQRT_2,
                        ],
                    }),
                })
                .collect();
            let actuators: Vec<ActuatorInfo> = actuators
                .into_iter()
                .enumerate()
                .map(|(i, (mode, winch, lim))| ActuatorInfo {
                    name: format!("act{i}"),
                    kind: if winch { ActuatorKind::Winch } else { ActuatorKind::Motor },
                    joint: joints.get(i).map(|j| j.name.clone()),
                    mode,
                    limits: if winch { None } else { Some([-lim.abs(), lim.abs()]) },
                })
                .collect();
            let joystick = if actuators.is_empty() {
                vec![]
            } else {
                bindings
                    .into_iter()
                    .map(|(axis, i, a, scale)| JoystickBinding {
                        input: if axis { JoystickInput::Axis(i) } else { JoystickInput::Button(i * 2) },
                        actuator: actuators[a.index(actuators.len())].name.clone(),
                        mode: ActuatorMode::Velocity,
                        scale,
                    })
                    .collect()
            };
            let mut sensors = vec![SensorInfo::ContactSum {
                name: "sum".into(),
                bodies: vec![bodies[0].id],
                with: (bodies.len() > 1).then(|| vec![bodies[1].id]),
            }];
            if let Some(j) = joints.first() {
                sensors.push(SensorInfo::Joint { name: "j0.reaction".into(), joint: j.name.clone() });
                sensors.push(SensorInfo::Cable { name: "rope".into(), joints: vec![j.name.clone()] });
            }
            SceneDescription {
                world: "test_world-1".into(),
                scene: "scenes/test.toml".into(),
                timestep,
                gravity,
                bodies,
                joints,
                actuators,
                joystick,
                sensors,
            }
        })
}

/// Any valid message.
pub fn message() -> impl Strategy<Value = Message> {
    prop_oneof![
        pose_frame().prop_map(Message::Pose),
        solver_stats().prop_map(Message::Stats),
        input().prop_map(Message::Input),
        control_request().prop_map(Message::ControlRequest),
        control_reply().prop_map(Message::ControlReply),
        scene().prop_map(Message::Scene),
    ]
}

pub fn name(s: &str) -> ActuatorName {
    ActuatorName::new(s).unwrap()
}

pub fn sample_body(id: u32) -> BodyPose {
    BodyPose {
        id,
        flags: 0,
        position: [1.0, 2.0, 0.5],
        orientation: [0.0, 0.0, 0.0, 1.0],
        linear_velocity: [0.25, 0.0, -1.0],
        angular_velocity: [0.0, 0.0, 0.5],
    }
}

pub fn sample_pose() -> PoseFrame {
    PoseFrame {
        sequence: 1,
        sim_time: 0.5,
        wall_time_ns: 1_700_000_000_000_000_000,
        bodies: vec![sample_body(7)],
    }
}

pub fn sample_scene() -> SceneDescription {
    SceneDescription {
        world: "demo".into(),
        scene: "winch".into(),
        timestep: 1.0 / 60.0,
        gravity: [0.0, 0.0, -9.81],
        bodies: vec![
            BodyInfo {
                id: 0,
                name: "ground".into(),
                kind: BodyKind::Static,
                mass: 0.0,
                visuals: Vec::new(),
                colliders: vec![Collider {
                    shape: Shape::Box { half_extents: [10.0, 10.0, 0.5] },
                    position: [0.0, 0.0, -0.5],
                    orientation: [0.0, 0.0, 0.0, 1.0],
                }],
            },
            BodyInfo {
                id: 1,
                name: "drum".into(),
                kind: BodyKind::Dynamic,
                mass: 400.0,
                visuals: Vec::new(),
                colliders: vec![Collider {
                    shape: Shape::Cylinder { radius: 0.3, half_height: 0.5 },
                    position: [0.0; 3],
                    orientation: [0.0, 0.0, 0.0, 1.0],
                }],
            },
        ],
        joints: vec![JointInfo {
            name: "drum_axle".into(),
            kind: JointKind::Hinge,
            parent: Some(0),
            child: 1,
            frame: Some(JointFrame {
                body: Some(1),
                position: [0.0, 0.0, 0.5],
                orientation: [0.0, 0.0, 0.0, 1.0],
            }),
        }],
        actuators: vec![
            ActuatorInfo {
                name: "winch".into(),
                kind: ActuatorKind::Winch,
                joint: Some("drum_axle".into()),
                mode: ActuatorMode::Velocity,
                limits: Some([-2.0, 2.0]),
            },
            ActuatorInfo {
                name: "slew".into(),
                kind: ActuatorKind::Motor,
                joint: None,
                mode: ActuatorMode::Velocity,
                limits: None,
            },
        ],
        joystick: vec![JoystickBinding {
            input: JoystickInput::Axis(1),
            actuator: "winch".into(),
            mode: ActuatorMode::Velocity,
            scale: 2.0,
        }],
        sensors: vec![
            SensorInfo::Drum { name: "drum.torque".into(), joint: "drum_axle".into() },
            SensorInfo::ContactSum { name: "base".into(), bodies: vec![1], with: Some(vec![0]) },
            SensorInfo::Tipping { name: "lmi".into(), bodies: vec![1], touch: 0.001 },
        ],
    }
}

/// One valid sample frame of every kind.
pub fn sample_frames() -> Vec<(Kind, Vec<u8>)> {
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let mut pose = sample_pose();
    pose.bodies.push(BodyPose { id: 9, flags: BODY_ASLEEP, orientation: [h, 0.0, 0.0, h], ..sample_body(9) });
    let island = IslandStats {
        variant: SolverVariant::Skyline,
        rows: 30,
        tight: 12,
        solve_us: 40.0,
        ..Default::default()
    };
    let stats = SolverStats {
        sequence: 1,
        sim_time: 0.5,
        step_wall_us: 900.0,
        islands: vec![island, island],
        totals: StepTotals::from_islands(&[island, island]),
        ..Default::default()
    };
    let msgs = [
        Message::Pose(pose),
        Message::Stats(stats),
        Message::Input(InputCommand::Joystick(Joystick::new(5, 2, &[0.5, -0.25], 0b11, 4).unwrap())),
        Message::Input(InputCommand::Winch(WinchCommand {
            sequence: 6,
            source_id: 2,
            actuator: name("winch"),
            drum_speed: 1.5,
        })),
        Message::Input(InputCommand::Boom(BoomCommand {
            sequence: 7,
            source_id: 2,
            targets: vec![
                BoomTarget { actuator: name("slew"), value: 0.1 },
                BoomTarget { actuator: name("lift"), value: -0.2 },
            ],
        })),
        Message::Input(InputCommand::Actuator(ActuatorCommand {
            sequence: 8,
            source_id: 2,
            mode: ActuatorMode::Position,
            actuator: name("boom/lift"),
            value: 0.75,
        })),
        Message::ControlRequest(ControlRequest {
            id: 3,
            command: ControlCommand::SetVariant { variant: SolverVariant::Auto },
        }),
        Message::ControlReply(ControlReply::error(3, ControlErrorCode::Busy, "stepping")),
        Message::Scene(sample_scene()),
        Message::Signals({
            let mut s = sample_signals();
            s.channels.push(SignalChannel { name: name("lmi/percent"), dropout: true, value: 0.0 });
            s
        }),
        Message::Events(sample_events()),
        Message::Applied(AppliedFrame {
            sequence: 12,
            sim_time: 0.2,
            records: vec![
                AppliedRecord { kind: AppliedKind::Input, bytes: vec![1, 2, 3, 4, 5] },
                AppliedRecord { kind: AppliedKind::Deadman, bytes: vec![] },
            ],
        }),
        Message::Keyframe {
            sequence: 12,
            sim_time: 0.2,
            reason: KeyframeReason::Periodic,
            snapshot: [&SNAPSHOT_MAGIC[..], &[1, 2, 3]].concat(),
        },
    ];
    msgs.iter()
        .map(|m| {
            let mut b = Vec::new();
            m.encode(&mut b).unwrap();
            (m.kind(), b)
        })
        .collect()
}

pub fn signal_channel() -> impl Strategy<Value = SignalChannel> {
    (actuator_name(), any::<bool>(), finite()).prop_map(|(name, dropout, value)| SignalChannel {
        name,
        dropout,
        value: if dropout { 0.0 } else { value },
    })
}

pub fn contact_record() -> impl Strategy<Value = ContactRecord> {
    (any::<(u32, u32)>(), 0u8..3, vec3(), non_negative(), non_negative(), vec3(), vec3()).prop_map(
        |((a, b), s, point, n, f, normal, friction)| ContactRecord {
            body_a: a,
            body_b: b,
            state: ContactCode::from_code(s).unwrap(),
            point,
            normal_force: n,
            friction_force: f,
            normal,
            friction,
        },
    )
}

pub fn signals_frame() -> impl Strategy<Value = SignalsFrame> {
    (
        any::<u64>(),
        non_negative(),
        any::<(u64, u32, u32)>(),
        prop::collection::vec(signal_channel(), 0..16),
        prop::collection::vec(contact_record(), 0..8),
    )
        .prop_map(
            |(sequence, sim_time, (events_total, faults_applied, faults_rejected), channels, contacts)| {
                SignalsFrame {
                    sequence,
                    sim_time,
                    events_total,
                    faults_applied,
                    faults_rejected,
                    channels,
                    contacts,
                }
            },
        )
}

pub fn events_frame() -> impl Strategy<Value = EventsFrame> {
    let event = (actuator_name(), 0u8..4, non_negative(), finite(), finite()).prop_map(
        |(name, k, time, value, level)| EventRecord {
            name,
            kind: EventCode::from_code(k).unwrap(),
            time,
            value,
            level,
        },
    );
    (any::<u64>(), non_negative(), any::<u64>(), prop::collection::vec(event, 0..8)).prop_map(
        |(sequence, sim_time, events_total, events)| EventsFrame { sequence, sim_time, events_total, events },
    )
}

/// The golden signals frame of the README.
pub fn sample_signals() -> SignalsFrame {
    SignalsFrame {
        sequence: 12,
        sim_time: 0.2,
        events_total: 3,
        faults_applied: 1,
        faults_rejected: 0,
        channels: vec![SignalChannel { name: name("hoist/hook"), dropout: false, value: 19620.0 }],
        contacts: vec![ContactRecord {
            body_a: 5,
            body_b: 0,
            state: ContactCode::Slip,
            point: [1.0, -0.5, 0.0],
            normal_force: 400.0,
            friction_force: 200.0,
            // From A (body 5) to B (the ground): down. The force on the ground, 400 N along it,
            // pushes the ground down; body 5 slides towards -x, so the friction on the ground is
            // along -x and on body 5 along +x.
            normal: [0.0, 0.0, -1.0],
            friction: [-200.0, 0.0, 0.0],
        }],
    }
}

/// The golden events frame of the README.
pub fn sample_events() -> EventsFrame {
    EventsFrame {
        sequence: 12,
        sim_time: 0.2,
        events_total: 3,
        events: vec![EventRecord {
            name: name("rope-parted"),
            kind: EventCode::Fault,
            time: 0.2,
            value: 1997.0,
            level: 1962.0,
        }],
    }
}

/// The golden stats frame of the README: one island, every fixed field non-trivial.
pub fn sample_stats() -> SolverStats {
    let island = IslandStats {
        variant: SolverVariant::Skyline,
        status: SolveStatus::Inexact,
        fallback: true,
        rows: 24,
        bodies: 3,
        pivot_steps: 17,
        tight: 10,
        iterations: 0,
        solve_us: 312.25,
        residual_rel: 0.0009765625,
    };
    SolverStats {
        sequence: 420,
        sim_time: 7.0,
        step_wall_us: 850.5,
        overruns: 2,
        totals: StepTotals::from_islands(&[island]),
        inputs: InputHealth {
            accepted: 1200,
            rejected: [3, 1, 2, 2, 4, 1, 5, 1, 1],
            deadman_trips: 1,
            deadman_active: true,
        },
        islands: vec![island],
        unstable: true,
        unstable_steps: 2,
        degraded: DegradedSolves { capped: 3, inexact: 2, budget: 1, fallback: 4 },
    }
}
