//! `atrium`: an indirect-heavy interior in the spirit of the Sponza and Sibenik test scenes.
//!
//! Units are metres, +y is up, the nave runs along z and the camera looks towards +z (so +x
//! is on the left of the image).
//!
//! ```text
//!  cross-section, looking down the nave (towards +z, hence +x on the left):
//!
//!   x =   7     4.2 4        0        -4 -4.2     -7
//!   y = 12 +-------+-+--------------------+-+-------+  ceiling; coffers over the nave, a
//!          |       |^|    coffer beams    |^|       |  roof slot above the camera
//!          |gallery| | upper arcade       | |gallery|
//!  y = 8.3 |      *=|  (columns at 0.65   |=*       |  * emissive strips on the rails,
//!  y = 7.3 |=======#|   scale, arches)    |#========|    facing up; # solid parapets
//!  y = 7   |       +-+                    +-+       |
//!          | aisle |a|       nave         |a| aisle |  a: lower arcade (columns on 3 m
//!  y = 5   |       |c|                    |c|       |     bays, round arches above)
//!          |       |c|     sun patch      |c|       |  drapes hang in some lower bays
//!  y = 0   +---------------------------------------+
//! ```
//!
//! - The hall is a closed box, x ∈ [-7, 7], y ∈ [0, 12], z ∈ [-15, 15], whose only opening is
//!   a slot in the nave ceiling (|x| < 3.6, z ∈ [-12, -4.5]) with a short lantern shaft
//!   above it. The slot is above and behind the camera's frustum; the coffer beams cross it,
//!   so the sun patch it lets in is striped with their shadows.
//! - Two colonnades at x = ±4 split the hall into a nave and two aisles: nine fluted columns a
//!   side on 3 m bays carry a wall pierced by semicircular arches. Galleries over the aisles
//!   have a solid parapet with a polished rail and an upper order (the same column mesh,
//!   instanced at 0.65 scale) with its own arches up to the ceiling. One column mesh placed 36
//!   times exercises the two-level BVH and supplies most of the triangles.
//! - Coloured drapes (red, blue, green, yellow; one mesh per colour, two instances each) hang
//!   from gilded rods in eight lower bays, and a harlequin tapestry hangs on the far wall to
//!   give the view a focus. A gilded sphere on a stone plinth stands in the sun patch.
//! - Light: the sun (a directional light) enters only through the slot and falls on the nave
//!   floor, the +x arcade and the red drape ahead of the camera: hard shadows of the beams,
//!   columns and plinth, and red bounced onto the stone around it. Two emissive strips lie on
//!   the parapet rails facing up; from anywhere below the rails (the camera included) the
//!   rails hide them, so they show only through the ceiling they wash. Everything except the
//!   sun patch and that ceiling is lit by light that has bounced at least once.
//!
//! About 190k triangles after instancing (51k unique); built in a few milliseconds.

use std::f32::consts::{FRAC_PI_2, PI, TAU};

use glam::{Mat4, Vec2, Vec3};

use crate::shapes::{
    aabox, arc, cylinder, grid, lathe, merge, panel, push_quad, sphere, with_mirror,
};
use crate::{
    BsdfSpec, Camera, FovAxis, Instance, Light, Material, Mesh, RenderDefaults, Roughness, Scene,
    Texture,
};

// ---- Layout (metres) --------------------------------------------------------------------

/// Outer walls at x = ±HALF_WIDTH.
const HALF_WIDTH: f32 = 7.0;
/// End walls at z = ±HALF_LENGTH.
const HALF_LENGTH: f32 = 15.0;
/// Ceiling height.
const HEIGHT: f32 = 12.0;
/// Column spacing along the nave (ten bays).
const BAY: f32 = 3.0;
/// Axis of the lower colonnades (x = ±ARCADE_X).
const ARCADE_X: f32 = 4.0;
/// Half thickness of the wall the lower arches are cut into.
const ARCADE_HALF_THICKNESS: f32 = 0.4;
/// Height of a lower column, plinth to abacus top; the lower arches spring here.
const COLUMN_HEIGHT: f32 = 5.0;
/// Radius of the lower arches' intrados (crown at 6.2 m).
const ARCH_RADIUS: f32 = 1.2;
/// Underside of the gallery floor slab (top of the lower arcade wall).
const SLAB_BOTTOM: f32 = 7.0;
/// Gallery floor level.
const GALLERY_Y: f32 = 7.3;
/// Parapet top (below the rail).
const PARAPET_TOP: f32 = 8.2;
/// Axis of the upper colonnades, set back behind the parapet.
const UPPER_X: f32 = 4.2;
/// The upper columns are the lower column mesh at this scale.
const UPPER_SCALE: f32 = 0.65;
/// Radius of the upper arches.
const UPPER_ARCH_RADIUS: f32 = 1.15;
/// Half thickness of the upper arcade wall.
const UPPER_HALF_THICKNESS: f32 = 0.25;
/// The roof slot: |x| < SLOT_HALF_X, SLOT_Z.0 < z < SLOT_Z.1 (on the coffer grid lines).
const SLOT_HALF_X: f32 = 3.6;
const SLOT_Z: (f32, f32) = (-12.0, -4.5);
/// Top of the lantern shaft above the slot.
const SHAFT_TOP: f32 = 13.2;
/// Depth of the coffer beams below the ceiling.
const BEAM_DEPTH: f32 = 0.35;
/// Top of the parapet rail.
const RAIL_TOP: f32 = PARAPET_TOP + 0.1;
/// The emissive strips on the parapet rails: x range (mirrored for the left side).
const STRIP_X: (f32, f32) = (3.6, 3.85);
/// Height of the strips above the rail (clear of the renderer's ray offsets).
const STRIP_LIFT: f32 = 0.02;
/// Overlap of the shell's panels at edges and corners so no ray slips between them.
const SEAM: f32 = 0.05;

/// Where the sun's light travels: steeply down (54° elevation), towards +z (away from the
/// camera) and +x, so its patch reaches the +x arcade and the red drape there.
const SUN_DIRECTION: Vec3 = Vec3::new(0.35, -1.0, 0.65);

// ---- Architectural parts ----------------------------------------------------------------

/// A lower column with its base at the origin, axis +y, 5 m tall: square plinth, Attic base
/// (torus, scotia, torus), fluted shaft with entasis, astragal, echinus and abacus. Smooth
/// normals throughout; about 3.4k triangles, so the 36 instances dominate the count.
fn column() -> Mesh {
    const SEGMENTS: u32 = 32;
    let v = Vec2::new;
    // Sections of revolution, each smooth; sharp edges fall between sections.
    let sections: Vec<Vec<Vec2>> = vec![
        // Lower torus, sitting on the plinth.
        arc(v(0.43, 0.37), 0.07, -FRAC_PI_2, FRAC_PI_2, 8),
        vec![v(0.43, 0.44), v(0.40, 0.44)],
        // Scotia: a concave hollow.
        (0..=4)
            .map(|k| {
                let t = k as f32 / 4.0;
                v(0.40 - 0.03 * (PI * t).sin(), 0.44 + 0.07 * t)
            })
            .collect(),
        vec![v(0.40, 0.51), v(0.36, 0.51)],
        // Upper torus; the shaft starts inside it so no seam shows.
        arc(v(0.36, 0.55), 0.04, -FRAC_PI_2, FRAC_PI_2, 6),
        // Astragal ring hiding the shaft's top edge.
        arc(v(0.31, 4.42), 0.035, -FRAC_PI_2, FRAC_PI_2, 6),
        // Echinus: a quarter ellipse flaring out to the abacus.
        (0..=8)
            .map(|k| {
                let a = k as f32 / 8.0 * FRAC_PI_2;
                v(0.30 + 0.22 * a.sin(), 4.76 - 0.31 * a.cos())
            })
            .collect(),
    ];
    let mut parts = vec![aabox(
        Vec3::new(-0.5, 0.0, -0.5),
        Vec3::new(0.5, 0.3, 0.5),
        0,
    )];
    parts.extend(sections.iter().map(|s| lathe(s, SEGMENTS)));
    parts.push(fluted_shaft(0.57, 4.45, 0.36, 0.31));
    parts.push(aabox(
        Vec3::new(-0.56, 4.76, -0.56),
        Vec3::new(0.56, COLUMN_HEIGHT, 0.56),
        0,
    ));
    merge("column", 0, parts)
}

/// A shaft from `y0` to `y1` tapering from radius `r0` to `r1` (with a slight entasis), cut
/// by 20 concave flutes.
fn fluted_shaft(y0: f32, y1: f32, r0: f32, r1: f32) -> Mesh {
    const FLUTES: u32 = 20;
    const PER_FLUTE: u32 = 5;
    const RINGS: u32 = 6;
    const DEPTH: f32 = 0.028;
    let segments = FLUTES * PER_FLUTE;
    grid(segments, RINGS, true, |i, j| {
        let t = j as f32 / RINGS as f32;
        // Entasis: the taper is concentrated in the upper part of the shaft.
        let radius = r0 + (r1 - r0) * t.powf(1.6);
        // Within a flute (k = 1..PER_FLUTE-1) the surface is cut in; k = 0 is the arris.
        let k = i % PER_FLUTE;
        let cut = DEPTH * (PI * k as f32 / PER_FLUTE as f32).sin();
        let phi = i as f32 / segments as f32 * TAU;
        let r = radius - cut;
        Vec3::new(r * phi.cos(), y0 + (y1 - y0) * t, -r * phi.sin())
    })
}

/// One bay of an arcade wall: the block x ∈ [x_lo, x_hi], z ∈ [z0, z1], y ∈ [y_spring, y_top]
/// pierced by a semicircular arch of `radius` centred on the bay and springing at `y_spring`.
/// Both faces and the soffit (intrados); the top, bottom and ends abut other solids. Flat
/// shaded, no uvs.
#[allow(clippy::too_many_arguments)]
fn arch_bay(
    x_lo: f32,
    x_hi: f32,
    z0: f32,
    z1: f32,
    y_spring: f32,
    y_top: f32,
    radius: f32,
    segments: u32,
) -> Mesh {
    let zc = 0.5 * (z0 + z1);
    let h = y_top - y_spring;
    // Angles from the arch centre, π (the z0 side) down to 0; the face's top corners must be
    // vertices of the outer outline or its quads would cut them off.
    let mut thetas: Vec<f32> = (0..=segments)
        .map(|k| PI * (1.0 - k as f32 / segments as f32))
        .collect();
    thetas.push(h.atan2(z0 - zc));
    thetas.push(h.atan2(z1 - zc));
    thetas.sort_by(|a, b| b.total_cmp(a));
    thetas.dedup_by(|a, b| (*a - *b).abs() < 1e-4);
    // Inner (intrados) point and the point where the same ray from the centre leaves the block.
    let inner = |t: f32| Vec2::new(zc + radius * t.cos(), y_spring + radius * t.sin());
    let outer = |t: f32| {
        let (s, c) = t.sin_cos();
        let mut d = f32::INFINITY;
        if c < -1e-6 {
            d = d.min((z0 - zc) / c);
        }
        if c > 1e-6 {
            d = d.min((z1 - zc) / c);
        }
        if s > 1e-6 {
            d = d.min(h / s);
        }
        Vec2::new(zc + d * c, y_spring + d * s)
    };
    let at = |x: f32, p: Vec2| Vec3::new(x, p.y, p.x);
    let mut mesh = Mesh {
        name: "arch".into(),
        ..Default::default()
    };
    for w in thetas.windows(2) {
        let (i0, i1, o0, o1) = (inner(w[0]), inner(w[1]), outer(w[0]), outer(w[1]));
        for (x, facing) in [(x_lo, -Vec3::X), (x_hi, Vec3::X)] {
            push_quad(
                &mut mesh,
                [at(x, i0), at(x, i1), at(x, o1), at(x, o0)],
                facing,
            );
        }
        // The soffit faces the arch's axis.
        let mid = 0.5 * (i0 + i1);
        let towards_axis = Vec3::new(0.0, y_spring - mid.y, zc - mid.x);
        push_quad(
            &mut mesh,
            [at(x_lo, i0), at(x_lo, i1), at(x_hi, i1), at(x_hi, i0)],
            towards_axis,
        );
    }
    mesh
}

/// A drape hanging from its top edge along +z (z ∈ [0, width]) down to y = -height, in the
/// x = 0 plane with folds displacing it in x. The folds deepen towards the hem and a second
/// harmonic keeps them from looking machined. Finely subdivided: the folds' self-shadowing
/// is the point.
fn drape(width: f32, height: f32, folds: f32, cols: u32, rows: u32) -> Mesh {
    grid(cols, rows, false, |i, j| {
        let u = i as f32 / cols as f32;
        let v = j as f32 / rows as f32;
        let amplitude = 0.05 + 0.1 * v;
        let x = amplitude
            * ((TAU * folds * u).sin() + 0.3 * (TAU * (2.0 * folds + 1.0) * u + 1.3).sin());
        // A slightly uneven hem.
        let hem = 0.04 * v * (TAU * 1.5 * u + 0.5).sin();
        Vec3::new(x, -height * v + hem, width * u)
    })
}

// ---- The scene --------------------------------------------------------------------------

fn diffuse(scene: &mut Scene, name: &str, rgb: Vec3) -> usize {
    scene.add_material(Material::diffuse(name, rgb))
}

/// Builds the atrium scene (see the module documentation for the layout).
pub(crate) fn atrium() -> Scene {
    let mut scene = Scene {
        name: "atrium".into(),
        meshes: vec![],
        instances: vec![],
        materials: vec![],
        lights: vec![],
        camera: Camera {
            // Eye height, just off the axis a third of the way in, looking down the nave and
            // slightly up so both storeys and the far wall are in view while the roof slot
            // (overhead) stays above the frustum's top plane.
            origin: Vec3::new(-0.5, 1.7, -10.5),
            target: Vec3::new(0.5, 3.0, HALF_LENGTH),
            up: Vec3::Y,
            fov: 65.0,
            fov_axis: FovAxis::X,
            lens: Default::default(),
            filter: Default::default(),
        },
        defaults: RenderDefaults {
            width: 512,
            height: 512,
            spp: 16,
            max_depth: 8,
        },
        media: Default::default(),
    };

    // Materials: pale, nearly neutral stones so bounced light carries far and takes on the
    // colour of what it bounced off; saturated drapes so there is colour to take on.
    let floor = scene.add_material(Material {
        name: "floor".into(),
        bsdf: BsdfSpec::Diffuse {
            reflectance: Texture::Checkerboard {
                color0: Vec3::new(0.80, 0.80, 0.78),
                color1: Vec3::new(0.55, 0.55, 0.53),
                scale: 1.0,
            },
        },
        emission: Vec3::ZERO,
        two_sided: true,
        emission_map: None,
        spectra: Default::default(),
    });
    let wall = diffuse(&mut scene, "wall", Vec3::new(0.74, 0.73, 0.70));
    let stone = diffuse(&mut scene, "stone", Vec3::new(0.76, 0.76, 0.73));
    let ceiling = diffuse(&mut scene, "ceiling", Vec3::new(0.78, 0.78, 0.76));
    let marble = diffuse(&mut scene, "column", Vec3::new(0.80, 0.80, 0.78));
    let rail = scene.add_material(Material {
        name: "green-marble".into(),
        bsdf: BsdfSpec::Plastic {
            diffuse: Texture::Constant(Vec3::new(0.10, 0.22, 0.16)),
            ior: 1.5,
            roughness: Roughness::ggx(0.15),
            nonlinear: false,
            exact_rough_coat: false,
        },
        emission: Vec3::ZERO,
        two_sided: true,
        emission_map: None,
        spectra: Default::default(),
    });
    let gold = scene.add_material(Material {
        name: "rough-gold".into(),
        bsdf: BsdfSpec::Conductor {
            eta: Vec3::new(0.143, 0.374, 1.442),
            k: Vec3::new(3.983, 2.385, 1.603),
            roughness: Roughness::ggx(0.3),
        },
        emission: Vec3::ZERO,
        two_sided: true,
        emission_map: None,
        spectra: Default::default(),
    });
    let drape_colours = [
        ("drape-red", Vec3::new(0.75, 0.08, 0.06)),
        ("drape-blue", Vec3::new(0.08, 0.16, 0.70)),
        ("drape-green", Vec3::new(0.10, 0.55, 0.12)),
        ("drape-yellow", Vec3::new(0.80, 0.64, 0.08)),
    ];
    let drape_materials: Vec<usize> = drape_colours
        .iter()
        .map(|&(name, rgb)| diffuse(&mut scene, name, rgb))
        .collect();
    let light = scene.add_material(
        Material::diffuse("strip-light", Vec3::ZERO).with_emission(Vec3::new(19.0, 18.0, 16.5)),
    );

    // Shell: a closed box except for the roof slot. Panels overlap at the seams.
    let (w, l, s) = (HALF_WIDTH + SEAM, HALF_LENGTH + SEAM, SEAM);
    let v = Vec3::new;
    scene.add_mesh(merge(
        "floor",
        floor,
        [panel(v(-w, 0.0, -l), v(w, 0.0, l), Vec3::Y, floor)],
    ));
    let (sx, (sz0, sz1)) = (SLOT_HALF_X, SLOT_Z);
    scene.add_mesh(merge(
        "walls",
        wall,
        [
            panel(
                v(-HALF_WIDTH, -s, -l),
                v(-HALF_WIDTH, HEIGHT + s, l),
                Vec3::X,
                wall,
            ),
            panel(
                v(HALF_WIDTH, -s, -l),
                v(HALF_WIDTH, HEIGHT + s, l),
                -Vec3::X,
                wall,
            ),
            panel(
                v(-w, -s, -HALF_LENGTH),
                v(w, HEIGHT + s, -HALF_LENGTH),
                Vec3::Z,
                wall,
            ),
            panel(
                v(-w, -s, HALF_LENGTH),
                v(w, HEIGHT + s, HALF_LENGTH),
                -Vec3::Z,
                wall,
            ),
            // The lantern shaft over the slot; it starts a little below the ceiling, hidden
            // by the coffer beams that frame the slot.
            panel(
                v(-sx, HEIGHT - s, sz0 - s),
                v(-sx, SHAFT_TOP, sz1 + s),
                Vec3::X,
                wall,
            ),
            panel(
                v(sx, HEIGHT - s, sz0 - s),
                v(sx, SHAFT_TOP, sz1 + s),
                -Vec3::X,
                wall,
            ),
            panel(
                v(-sx, HEIGHT - s, sz0),
                v(sx, SHAFT_TOP, sz0),
                Vec3::Z,
                wall,
            ),
            panel(
                v(-sx, HEIGHT - s, sz1),
                v(sx, SHAFT_TOP, sz1),
                -Vec3::Z,
                wall,
            ),
        ],
    ));
    let down = -Vec3::Y;
    let mut ceiling_parts = vec![
        panel(v(-w, HEIGHT, -l), v(w, HEIGHT, sz0), down, ceiling),
        panel(v(-w, HEIGHT, sz1), v(w, HEIGHT, l), down, ceiling),
        panel(v(-w, HEIGHT, sz0), v(-sx, HEIGHT, sz1), down, ceiling),
        panel(v(sx, HEIGHT, sz0), v(w, HEIGHT, sz1), down, ceiling),
    ];
    // Coffers over the nave: transverse beams every half bay, longitudinal ones every 1.2 m.
    // They also cross the slot, striping the sun patch with shadows.
    let nave_half = UPPER_X - UPPER_HALF_THICKNESS;
    let beam_y = (HEIGHT - BEAM_DEPTH, HEIGHT);
    for k in 1..20 {
        let z = -HALF_LENGTH + 0.5 * BAY * k as f32;
        ceiling_parts.push(aabox(
            v(-nave_half, beam_y.0, z - 0.1),
            v(nave_half, beam_y.1, z + 0.1),
            ceiling,
        ));
    }
    for k in -3..=3 {
        let x = 1.2 * k as f32;
        ceiling_parts.push(aabox(
            v(x - 0.1, beam_y.0, -HALF_LENGTH),
            v(x + 0.1, beam_y.1, HALF_LENGTH),
            ceiling,
        ));
    }
    scene.add_mesh(merge("ceiling", ceiling, ceiling_parts));

    // Arcades, gallery slabs, parapets and end pilasters: built for the right (+x) side and
    // mirrored.
    let bays = || (0..10).map(|k| -HALF_LENGTH + BAY * k as f32);
    let upper_spring = GALLERY_Y + UPPER_SCALE * COLUMN_HEIGHT;
    let mut arches = Vec::new();
    for z0 in bays() {
        arches.push(arch_bay(
            ARCADE_X - ARCADE_HALF_THICKNESS,
            ARCADE_X + ARCADE_HALF_THICKNESS,
            z0,
            z0 + BAY,
            COLUMN_HEIGHT,
            SLAB_BOTTOM,
            ARCH_RADIUS,
            48,
        ));
        arches.push(arch_bay(
            UPPER_X - UPPER_HALF_THICKNESS,
            UPPER_X + UPPER_HALF_THICKNESS,
            z0,
            z0 + BAY,
            upper_spring,
            HEIGHT,
            UPPER_ARCH_RADIUS,
            40,
        ));
    }
    scene.add_mesh(with_mirror(merge("arches", stone, arches)));

    let inner_face = ARCADE_X - ARCADE_HALF_THICKNESS;
    let mut structure = vec![
        // Gallery floor slab over the aisle.
        aabox(
            v(inner_face, SLAB_BOTTOM, -HALF_LENGTH),
            v(HALF_WIDTH, GALLERY_Y, HALF_LENGTH),
            stone,
        ),
        // Parapet: solid, under the rail that carries the emissive strip.
        aabox(
            v(inner_face, GALLERY_Y, -HALF_LENGTH),
            v(inner_face + 0.25, PARAPET_TOP, HALF_LENGTH),
            stone,
        ),
    ];
    for z in [-HALF_LENGTH, HALF_LENGTH] {
        // Half-pilasters where the arcades meet the end walls carry the end arches.
        let lower = (z.signum() * (HALF_LENGTH - 0.55), z);
        let upper = (z.signum() * (HALF_LENGTH - 0.36), z);
        structure.push(aabox(
            v(ARCADE_X - 0.5, 0.0, lower.0.min(lower.1)),
            v(ARCADE_X + 0.5, COLUMN_HEIGHT, lower.0.max(lower.1)),
            stone,
        ));
        structure.push(aabox(
            v(UPPER_X - 0.33, GALLERY_Y, upper.0.min(upper.1)),
            v(UPPER_X + 0.33, upper_spring, upper.0.max(upper.1)),
            stone,
        ));
    }
    scene.add_mesh(with_mirror(merge("structure", stone, structure)));
    scene.add_mesh(with_mirror(merge(
        "parapet-rail",
        rail,
        [aabox(
            v(inner_face - 0.05, PARAPET_TOP, -HALF_LENGTH),
            v(inner_face + 0.3, RAIL_TOP, HALF_LENGTH),
            rail,
        )],
    )));

    // Columns: one mesh, 36 instances (the upper order is the same column scaled down), which
    // exercises the renderer's two-level hierarchy.
    let mut column = column();
    column.material = marble;
    scene.meshes.push(column);
    let column_mesh = scene.meshes.len() - 1;
    for k in 1..10 {
        let z = -HALF_LENGTH + BAY * k as f32;
        for side in [-1.0, 1.0] {
            scene.instances.push(Instance {
                mesh: column_mesh,
                transform: Mat4::from_translation(v(side * ARCADE_X, 0.0, z)),
            });
            scene.instances.push(Instance {
                mesh: column_mesh,
                transform: Mat4::from_translation(v(side * UPPER_X, GALLERY_Y, z))
                    * Mat4::from_scale(Vec3::splat(UPPER_SCALE)),
            });
        }
    }

    // Drapes in eight lower bays, each colour twice (one mesh per colour, two instances), on
    // gilded rods just under the capitals. The red one in bay [-3, 0] on the +x side is in
    // the sun.
    let rod_y = 4.62;
    let (drape_z0, drape_width) = (0.45, BAY - 0.9);
    let placements = [
        // (colour index, side, bay start z); the bays behind the camera stay bare.
        (0, 1.0, -3.0),
        (0, -1.0, 6.0),
        (1, 1.0, 9.0),
        (1, -1.0, -3.0),
        (2, 1.0, -9.0),
        (2, -1.0, 3.0),
        (3, 1.0, 3.0),
        (3, -1.0, 12.0),
    ];
    let mut rods = Vec::new();
    for (colour, &material) in drape_materials.iter().enumerate() {
        let mut mesh = drape(drape_width, rod_y - 0.5, 6.0, 80, 36);
        mesh.name = drape_colours[colour].0.into();
        mesh.material = material;
        scene.meshes.push(mesh);
        let mesh = scene.meshes.len() - 1;
        for &(c, side, z0) in placements.iter().filter(|p| p.0 == colour) {
            debug_assert_eq!(c, colour);
            scene.instances.push(Instance {
                mesh,
                transform: Mat4::from_translation(v(side * ARCADE_X, rod_y - 0.04, z0 + drape_z0)),
            });
            rods.push(cylinder(
                &(Mat4::from_translation(v(side * ARCADE_X, rod_y, z0 + 0.3))
                    * Mat4::from_scale(v(0.03, 0.03, BAY - 0.6))),
                gold,
                16,
            ));
        }
    }
    // A harlequin tapestry on the far end wall gives the view down the nave a focus (and
    // exercises a texture on a curved, smooth-shaded mesh).
    let tapestry_material = scene.add_material(Material {
        name: "tapestry".into(),
        bsdf: BsdfSpec::Diffuse {
            reflectance: Texture::Checkerboard {
                color0: Vec3::new(0.08, 0.12, 0.50),
                color1: Vec3::new(0.72, 0.56, 0.16),
                scale: 8.0,
            },
        },
        emission: Vec3::ZERO,
        two_sided: true,
        emission_map: None,
        spectra: Default::default(),
    });
    let (tapestry_width, tapestry_top) = (4.8, 9.6);
    // Local frame: width along +z, folds along x; turned so the width runs along +x and the
    // folds stand off the wall (towards -z).
    let to_end_wall =
        Mat4::from_translation(v(-0.5 * tapestry_width, tapestry_top, HALF_LENGTH - 0.25))
            * Mat4::from_rotation_y(FRAC_PI_2);
    let mut tapestry = drape(tapestry_width, 7.0, 5.0, 96, 48).transformed(&to_end_wall);
    tapestry.name = "tapestry".into();
    tapestry.material = tapestry_material;
    scene.add_mesh(tapestry);
    rods.push(cylinder(
        &(Mat4::from_translation(v(
            -0.5 * tapestry_width - 0.3,
            tapestry_top + 0.05,
            HALF_LENGTH - 0.25,
        )) * Mat4::from_rotation_y(FRAC_PI_2)
            * Mat4::from_scale(v(0.04, 0.04, tapestry_width + 0.6))),
        gold,
        16,
    ));
    // A gilded sphere on a plinth in the sun patch: hard contact shadows on the floor.
    let (ox, oz) = (2.0, -0.5);
    rods.push(sphere(
        &(Mat4::from_translation(v(ox, 1.35, oz)) * Mat4::from_scale(Vec3::splat(0.35))),
        gold,
        32,
        64,
    ));
    scene.add_mesh(merge("gilding", gold, rods));
    scene.add_mesh(merge(
        "plinth",
        stone,
        [aabox(
            v(ox - 0.4, 0.0, oz - 0.4),
            v(ox + 0.4, 1.0, oz + 0.4),
            stone,
        )],
    ));

    // Hidden lights: strips lying on the parapet rails, facing up at the coffered ceiling and
    // the upper arcades. Anything below the rail top cannot see them.
    let strip_y = RAIL_TOP + STRIP_LIFT;
    let strip_z = HALF_LENGTH - 0.3;
    scene.add_mesh(merge(
        "strip-lights",
        light,
        [
            panel(
                v(STRIP_X.0, strip_y, -strip_z),
                v(STRIP_X.1, strip_y, strip_z),
                Vec3::Y,
                light,
            ),
            panel(
                v(-STRIP_X.1, strip_y, -strip_z),
                v(-STRIP_X.0, strip_y, strip_z),
                Vec3::Y,
                light,
            ),
        ],
    ));

    // The sun, through the slot only.
    scene.lights.push(Light::Directional {
        direction: SUN_DIRECTION.normalize(),
        irradiance: Vec3::new(8.0, 7.7, 7.2),
    });
    scene
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec4Swizzles;

    /// All triangles in world space, with whether they emit.
    fn world_triangles(scene: &Scene) -> Vec<([Vec3; 3], bool)> {
        let mut out = Vec::with_capacity(scene.triangle_count());
        for inst in &scene.instances {
            let mesh = &scene.meshes[inst.mesh];
            let emissive = scene.materials[mesh.material].is_emissive();
            for t in 0..mesh.triangle_count() {
                let tri = mesh
                    .triangle(t)
                    .map(|p| (inst.transform * p.extend(1.0)).xyz());
                out.push((tri, emissive));
            }
        }
        out
    }

    /// Whether the open segment from `a` to `b` crosses triangle `tri` (Möller–Trumbore).
    fn segment_hits(a: Vec3, b: Vec3, tri: &[Vec3; 3]) -> bool {
        let d = b - a;
        let (e1, e2) = (tri[1] - tri[0], tri[2] - tri[0]);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-12 {
            return false;
        }
        let inv = 1.0 / det;
        let s = a - tri[0];
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return false;
        }
        let q = s.cross(e1);
        let w = d.dot(q) * inv;
        if w < 0.0 || u + w > 1.0 {
            return false;
        }
        let t = e2.dot(q) * inv;
        t > 1e-4 && t < 1.0 - 1e-4
    }

    fn occluded(a: Vec3, b: Vec3, tris: &[([Vec3; 3], bool)]) -> bool {
        let (lo, hi) = (a.min(b), a.max(b));
        tris.iter().any(|(t, emissive)| {
            !emissive
                && t.iter()
                    .fold(Vec3::NEG_INFINITY, |m, p| m.max(*p))
                    .cmpge(lo)
                    .all()
                && t.iter()
                    .fold(Vec3::INFINITY, |m, p| m.min(*p))
                    .cmple(hi)
                    .all()
                && segment_hits(a, b, t)
        })
    }

    #[test]
    fn atrium_is_big_valid_and_framed() {
        let start = std::time::Instant::now();
        let scene = atrium();
        let built = start.elapsed();
        scene.validate().unwrap();
        assert_eq!(scene.name, "atrium");
        let n = scene.triangle_count();
        assert!((100_000..=250_000).contains(&n), "{n} triangles");
        let (lo, hi) = scene.bounds();
        let eye = scene.camera.origin;
        assert!(
            eye.cmpgt(lo).all() && eye.cmplt(hi).all(),
            "camera outside {lo} {hi}"
        );
        // Generous: debug builds of the test run unoptimised.
        assert!(built.as_millis() < 2000, "built in {built:?}");
    }

    #[test]
    fn emitters_are_hidden_from_the_camera() {
        let scene = atrium();
        let tris = world_triangles(&scene);
        let eye = scene.camera.origin;
        let emitters: Vec<_> = tris.iter().filter(|t| t.1).collect();
        assert!(!emitters.is_empty());
        // A lattice of points on every emissive triangle, corners included.
        const N: u32 = 6;
        for (tri, _) in emitters {
            for i in 0..=N {
                for j in 0..=N - i {
                    let (u, w) = (i as f32 / N as f32, j as f32 / N as f32);
                    let p = tri[0] + u * (tri[1] - tri[0]) + w * (tri[2] - tri[0]);
                    assert!(occluded(eye, p, &tris), "emitter point {p} is visible");
                }
            }
        }
    }

    #[test]
    fn roof_slot_is_out_of_frame_and_lets_the_sun_in() {
        let scene = atrium();
        let cam = &scene.camera;
        let (right, up, forward) = cam.basis();
        let (tw, th) = cam.half_extent(scene.defaults.width, scene.defaults.height);
        // The top plane of the view frustum, normal pointing out of the frustum.
        let top = right.cross(forward + th * up).normalize();
        let top = if top.dot(forward) > 0.0 { -top } else { top };
        assert!(top.dot(up) > 0.0 && tw > 0.0);
        // Every corner of the opening (bottom and top of the shaft) is above that plane, so the
        // sky can never be seen directly.
        for y in [HEIGHT - BEAM_DEPTH, SHAFT_TOP] {
            for x in [-SLOT_HALF_X, SLOT_HALF_X] {
                for z in [SLOT_Z.0, SLOT_Z.1] {
                    let p = Vec3::new(x, y, z);
                    assert!(top.dot(p - cam.origin) > 0.0, "slot corner {p} in view");
                }
            }
        }
        // The sun reaches the nave floor (between coffer beam shadows) in front of the
        // gilded plinth, and is blocked elsewhere.
        let tris = world_triangles(&scene);
        let towards_sun = -SUN_DIRECTION.normalize();
        let lit = Vec3::new(3.2, 0.0, 2.2);
        assert!(!occluded(lit, lit + 40.0 * towards_sun, &tris));
        let dark = Vec3::new(-2.0, 0.0, 10.0);
        assert!(occluded(dark, dark + 40.0 * towards_sun, &tris));
    }

    #[test]
    fn column_faces_point_away_from_its_axis() {
        // Lathe sections and shaft must wind outwards (or up, on ledges): a guard on the
        // hand-derived orientation of `lathe` and `fluted_shaft`.
        let col = column();
        for t in 0..col.triangle_count() {
            let [a, b, c] = col.triangle(t);
            let n = (b - a).cross(c - a);
            let centroid = (a + b + c) / 3.0;
            let radial = Vec3::new(centroid.x, 0.0, centroid.z);
            assert!(
                n.dot(radial) >= -1e-6 * n.length(),
                "triangle {t} faces inwards"
            );
        }
    }
}
