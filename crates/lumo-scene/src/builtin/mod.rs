//! Scenes that ship with lumo, addressed by name (`lumo render --list`).

mod atrium;
mod cornell;

use crate::{Scene, SceneError};

/// A built-in scene: its name, a one-line description and its constructor.
pub struct BuiltinScene {
    /// Name used on the command line.
    pub name: &'static str,
    /// One line for `lumo render --list`.
    pub description: &'static str,
    /// Builds the scene.
    pub build: fn() -> Scene,
}

/// All built-in scenes, the default first.
pub const BUILTIN_SCENES: &[BuiltinScene] = &[
    BuiltinScene {
        name: "cornell",
        description: "Mitsuba 3's cornell_box(): same geometry, reflectances, light and camera",
        build: cornell::cornell,
    },
    BuiltinScene {
        name: "cornell-spheres",
        description:
            "the Cornell box with a rough gold sphere, a glass sphere and a checkerboard floor",
        build: cornell::cornell_spheres,
    },
    BuiltinScene {
        name: "atrium",
        description: "a procedural hall with colonnades, arches and drapes, lit mostly indirectly",
        build: atrium::atrium,
    },
];

/// The built-in scene called `name`.
pub fn builtin_scene(name: &str) -> Result<Scene, SceneError> {
    BUILTIN_SCENES
        .iter()
        .find(|s| s.name == name)
        .map(|s| (s.build)())
        .ok_or_else(|| SceneError::UnknownBuiltin {
            name: name.to_string(),
            available: BUILTIN_SCENES
                .iter()
                .map(|s| s.name)
                .collect::<Vec<_>>()
                .join(", "),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_validates() {
        for s in BUILTIN_SCENES {
            let scene = (s.build)();
            scene
                .validate()
                .unwrap_or_else(|e| panic!("{}: {e}", s.name));
            assert_eq!(scene.name, s.name);
            assert!(scene.triangle_count() > 0);
        }
        assert!(builtin_scene("nope")
            .unwrap_err()
            .to_string()
            .contains("cornell"));
    }
}
