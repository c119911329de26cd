//! The scenes shipped in `scenes/`, embedded in the binary so that `--scene NAME` works from any
//! directory.

/// A built-in scene: its name, a one-line summary and the file text.
#[derive(Debug, Clone, Copy)]
pub struct BuiltinScene {
    /// Name (the file stem).
    pub name: &'static str,
    /// One line for `pivotsim-server scenes`.
    pub summary: &'static str,
    /// The scene file.
    pub text: &'static str,
}

macro_rules! scene {
    ($name:literal, $summary:literal) => {
        BuiltinScene {
            name: $name,
            summary: $summary,
            text: include_str!(concat!("../../../scenes/", $name, ".toml")),
        }
    };
}

/// All built-in scenes.
pub const BUILTIN: &[BuiltinScene] = &[
    scene!("pendulum", "a double pendulum on hinges: the smallest scene with joints"),
    scene!("box_stack", "ten boxes stacked on the ground, mass ratio 100 between neighbours"),
    scene!("hanging_chain", "a chain of 20 capsules on ball joints, released sideways"),
    scene!("forwarder", "a 16-link 1,900 kg forwarder crane grasps a 400 kg log, lifts it and slews"),
    scene!("winch", "a 400 kg drum winds a chain of 50 × 1 kg capsules dragged along the ground"),
    scene!("forklift", "a 3 t forklift lifts a crate on a pallet and turns 360° around a cone"),
    scene!("crane", "a 30 t mobile crane on outriggers hoists a 2 t concrete pipe on a 70 kg cable"),
    scene!(
        "offshore",
        "a 50 t knuckle-boom crane on a floating 5,500 t ship drags a 15 t module on deck and lifts it"
    ),
    scene!("vehicle", "a 15 t eight-wheeled armoured vehicle drives over bumps, stairs and hills"),
];

/// The built-in scene `name`.
pub fn builtin(name: &str) -> Option<&'static BuiltinScene> {
    BUILTIN.iter().find(|b| b.name == name)
}
