//! `scene`: the scene description from the `scene` queryable, as a summary or as JSON.

use std::fmt::Write as _;
use std::process::ExitCode;

use anyhow::Result;
use pivotsim_msgs as msgs;

use crate::common::Common;

/// `scene` options.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print the description as JSON (the wire form, pretty-printed).
    #[arg(long)]
    pub json: bool,
}

fn shape_summary(s: &msgs::Shape) -> String {
    match s {
        msgs::Shape::Ball { radius } => format!("ball r={radius}"),
        msgs::Shape::Box { half_extents: h } => format!("box {}×{}×{}", 2.0 * h[0], 2.0 * h[1], 2.0 * h[2]),
        msgs::Shape::Capsule { radius, half_height } => format!("capsule r={radius} l={}", 2.0 * half_height),
        msgs::Shape::Cylinder { radius, half_height } => {
            format!("cylinder r={radius} l={}", 2.0 * half_height)
        }
        msgs::Shape::ConvexHull { vertices } => format!("convex hull ({} points)", vertices.len()),
        msgs::Shape::Heightfield { rows, cols, extent, .. } => {
            format!("heightfield {rows}×{cols} over {}×{} m", extent[0], extent[1])
        }
        msgs::Shape::Trimesh { mesh } => match mesh {
            msgs::MeshData::Inline { vertices, triangles } => {
                format!("trimesh ({} vertices, {} triangles)", vertices.len(), triangles.len())
            }
            msgs::MeshData::Reference(r) => format!("trimesh ({r})"),
        },
    }
}

/// A human summary of a scene description.
pub fn summary(d: &msgs::SceneDescription) -> String {
    let mut s = String::new();
    let name = |id: Option<u32>| match id {
        None => "world".to_string(),
        Some(id) => d.body(id).map_or_else(|| format!("#{id}"), |b| b.name.clone()),
    };
    let _ = writeln!(s, "scene {} (world {})", d.scene, d.world);
    let _ = writeln!(
        s,
        "timestep {:.6} s ({:.1} Hz), gravity [{}, {}, {}] m/s²",
        d.timestep,
        1.0 / d.timestep,
        d.gravity[0],
        d.gravity[1],
        d.gravity[2]
    );
    let _ = writeln!(s, "\nbodies ({}):", d.bodies.len());
    for b in &d.bodies {
        let kind = format!("{:?}", b.kind).to_lowercase();
        let mass = if b.kind == msgs::BodyKind::Dynamic { format!("{} kg", b.mass) } else { String::new() };
        let shapes: Vec<String> = b.shapes().map(|c| shape_summary(&c.shape)).collect();
        let _ = writeln!(s, "  {:>4}  {:<20} {:<9} {:>10}  {}", b.id, b.name, kind, mass, shapes.join(", "));
    }
    let _ = writeln!(s, "\njoints ({}):", d.joints.len());
    for j in &d.joints {
        let kind = format!("{:?}", j.kind).to_lowercase();
        let _ = writeln!(s, "  {:<20} {:<9} {} → {}", j.name, kind, name(j.parent), name(Some(j.child)));
    }
    let _ = writeln!(s, "\nactuators ({}):", d.actuators.len());
    for a in &d.actuators {
        let kind = format!("{:?}", a.kind).to_lowercase();
        let limits = a.limits.map_or_else(|| "unbounded".to_string(), |l| format!("[{}, {}]", l[0], l[1]));
        let _ = writeln!(
            s,
            "  {:<20} {:<6} {:<9} {:<14} joint {}",
            a.name,
            kind,
            a.mode.name(),
            limits,
            a.joint.as_deref().unwrap_or("-")
        );
    }
    let _ = writeln!(s, "\njoystick bindings ({}):", d.joystick.len());
    for b in &d.joystick {
        let input = match b.input {
            msgs::JoystickInput::Axis(i) => format!("axis {i}"),
            msgs::JoystickInput::Button(i) => format!("button {i}"),
        };
        let _ = writeln!(s, "  {:<10} → {:<20} {:<9} × {}", input, b.actuator, b.mode.name(), b.scale);
    }
    s
}

/// Runs `scene`.
pub fn run(common: &Common, args: &Args) -> Result<ExitCode> {
    let link = common.open_zenoh()?;
    let d = link.scene(common.timeout_or(5.0))?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&d)?);
    } else {
        print!("{}", summary(&d));
    }
    Ok(ExitCode::SUCCESS)
}
