//! Mutation testing of the loaders: thousands of corrupted copies of the sample scenes (bit
//! flips, overwritten bytes, truncations, duplicated and deleted runs) must load or fail with
//! an error, never panic. `LUMO_FUZZ_ITERS=N` runs N mutations per file (default 300).

use crate::common;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use common::{load, scenes, temp_dir, write};
use lumo_scene::load::{load_mitsuba_str, load_ply_bytes, LoadOptions};

/// xorshift64*: deterministic, so a failure reproduces.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Interesting replacement bytes: digits, signs, XML and OBJ punctuation, extremes.
const SPICE: &[u8] = b"0123456789-+.eE/<>\"=$ \n\xff\x00";

fn mutate(rng: &mut Rng, data: &[u8]) -> Vec<u8> {
    let mut d = data.to_vec();
    for _ in 0..1 + rng.below(4) {
        if d.is_empty() {
            break;
        }
        let at = rng.below(d.len());
        match rng.below(6) {
            0 => d[at] ^= 1 << rng.below(8),
            1 => d[at] = SPICE[rng.below(SPICE.len())],
            2 => d.truncate(at),
            3 => {
                let len = rng.below(16).min(d.len() - at);
                let run: Vec<u8> = d[at..at + len].to_vec();
                let to = rng.below(d.len());
                d.splice(to..to, run);
            }
            4 => {
                let len = rng.below(16).min(d.len() - at);
                d.drain(at..at + len);
            }
            _ => d[at] = rng.next() as u8,
        }
    }
    d
}

#[test]
fn corrupted_scene_files_never_panic() {
    let iters: usize = std::env::var("LUMO_FUZZ_ITERS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(300);
    let dir = temp_dir("fuzz");
    // Self-contained samples (no relative references), one per reader.
    let samples = [
        "cornell.xml",
        "hierarchy.gltf",
        "hierarchy.glb",
        "meshes/pyramid_le.ply",
        "meshes/pyramid_be.ply",
        "meshes/pyramid_ascii.ply",
    ];
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut ok, mut failed, mut caught) = (0usize, 0usize, 0usize);
    for sample in samples {
        let original = std::fs::read(scenes().join(sample)).unwrap();
        let name = sample.rsplit('/').next().unwrap_or(sample);
        for i in 0..iters {
            let data = mutate(&mut rng, &original);
            let path = write(&dir, name, &data);
            match catch_unwind(AssertUnwindSafe(|| load(&path))) {
                Ok(Ok(_)) => ok += 1,
                Ok(Err(e)) => {
                    failed += 1;
                    // The glTF loader's last-resort guard around the gltf crate.
                    caught += e.to_string().contains("parser failed on") as usize;
                    assert!(
                        e.to_string().contains(name),
                        "{sample} #{i}: error lacks the file: {e}"
                    );
                }
                Err(_) => {
                    let keep = std::env::temp_dir().join(format!("lumo-fuzz-crash-{name}"));
                    std::fs::write(&keep, &data).ok();
                    panic!(
                        "{sample} mutation {i} panicked; input saved to {}",
                        keep.display()
                    );
                }
            }
        }
    }
    eprintln!(
        "{} mutated files: {ok} loaded, {failed} refused with an error ({caught} of them by the \
         guard around the gltf crate)",
        ok + failed
    );
    assert!(failed > 0 && ok > 0);
}

// Regressions: inputs that crashed the Mitsuba loader (stack overflow or allocation failure,
// both abort the process) before the bounds in load/mitsuba were added. They were found while
// fuzzing (docs/scenes.md, "Fuzzing"): by reading the loader for what a random mutation
// rarely builds, a `<ref>` back to an enclosing plugin or a self-multiplying `<default>`.

/// Loads Mitsuba XML from memory and returns the error text, which must name the file.
fn mitsuba_error(xml: &str) -> String {
    let path = Path::new("regression.xml");
    let e = load_mitsuba_str(xml, path, &LoadOptions::default())
        .expect_err("the scene must be refused");
    let text = e.to_string();
    assert!(text.starts_with("regression.xml:"), "{text}");
    text
}

#[test]
fn bsdf_referring_to_itself_is_an_error_not_a_stack_overflow() {
    let e = mitsuba_error(
        r#"<scene version="3.0.0">
<bsdf type="twosided" id="a"><ref id="a"/></bsdf>
<shape type="sphere"><ref id="a"/></shape>
</scene>"#,
    );
    assert!(e.contains("regression.xml:2") && e.contains("cycle"), "{e}");
}

#[test]
fn texture_referring_to_itself_is_an_error() {
    let e = mitsuba_error(
        r#"<scene version="3.0.0">
<texture type="checkerboard" id="t"><ref name="color0" id="t"/></texture>
<shape type="sphere"><bsdf type="diffuse"><ref name="reflectance" id="t"/></bsdf></shape>
</scene>"#,
    );
    assert!(e.contains("regression.xml:2") && e.contains("cycle"), "{e}");
}

#[test]
fn integrator_referring_to_itself_is_an_error() {
    let e = mitsuba_error(
        r#"<scene version="3.0.0">
<integrator type="aov" id="i"><ref id="i"/></integrator>
</scene>"#,
    );
    assert!(e.contains("regression.xml:2") && e.contains("cycle"), "{e}");
}

#[test]
fn long_ref_chains_are_bounded_but_short_ones_load() {
    // b1 .. bn, each a twosided wrapping a reference to the next, b(n+1) a diffuse. Declared
    // BSDFs are converted in file order, so converting b1 follows the whole chain at once.
    let chain = |n: usize, forward: bool| {
        let mut s = String::from("<scene version=\"3.0.0\">\n");
        let mut items: Vec<String> = (1..=n)
            .map(|i| {
                format!(
                    "<bsdf type=\"twosided\" id=\"b{i}\"><ref id=\"b{}\"/></bsdf>",
                    i + 1
                )
            })
            .collect();
        items.push(format!("<bsdf type=\"diffuse\" id=\"b{}\"/>", n + 1));
        if forward {
            // Each BSDF after the one it refers to: every step is already converted.
            items.reverse();
        }
        s += &items.join("\n");
        s += "\n<shape type=\"sphere\"><ref id=\"b1\"/></shape>\n\
              <emitter type=\"constant\"/>\n</scene>";
        s
    };
    let opts = LoadOptions::default();
    for (n, forward) in [(4, false), (10_000, true)] {
        let ok = load_mitsuba_str(&chain(n, forward), Path::new("chain.xml"), &opts);
        assert!(ok.is_ok(), "{n}: {:?}", ok.err());
    }
    assert!(mitsuba_error(&chain(10_000, false)).contains("nested more than"));
}

#[test]
fn deeply_nested_elements_are_an_error_not_a_stack_overflow() {
    let n = 100_000;
    let xml = format!(
        "<scene version=\"3.0.0\">{}{}</scene>",
        "<a>".repeat(n),
        "</a>".repeat(n)
    );
    let e = mitsuba_error(&xml);
    assert!(
        e.contains("regression.xml:1") && e.contains("nested more than"),
        "{e}"
    );
}

#[test]
fn self_multiplying_defaults_are_bounded() {
    // Each default is four copies of the one before: 16 * 4^15 bytes (16 GiB) at the end.
    let mut xml = String::from(
        "<scene version=\"3.0.0\">\n<default name=\"a0\" value=\"xxxxxxxxxxxxxxxx\"/>\n",
    );
    for i in 1..16 {
        let p = format!("$a{}", i - 1);
        xml += &format!("<default name=\"a{i}\" value=\"{p}{p}{p}{p}\"/>\n");
    }
    xml += "<shape type=\"sphere\"><string name=\"x\" value=\"$a15\"/></shape>\n</scene>";
    let e = mitsuba_error(&xml);
    assert!(e.contains("substitution would produce more than"), "{e}");
}

#[test]
fn ply_header_claiming_10_to_the_12_vertices_allocates_nothing_up_front() {
    for format in ["ascii", "binary_little_endian"] {
        let ply = format!(
            "ply\nformat {format} 1.0\nelement vertex 1000000000000\nproperty float x\n\
             property float y\nproperty float z\nelement face 1\n\
             property list uchar int vertex_indices\nend_header\n0 0 0\n"
        );
        let e = load_ply_bytes(
            ply.as_bytes(),
            Path::new("huge.ply"),
            &LoadOptions::default(),
        )
        .expect_err("refused");
        assert!(
            e.to_string().contains("huge.ply") && e.to_string().contains("more than the file"),
            "{e}"
        );
    }
}

/// Negative or NaN PLY vertex colours are read as 0 with one warning naming the file, as OBJ
/// `Kd` and glTF colours are: a colour cannot be negative, and the renderer would otherwise
/// emit negative light from the surface.
#[test]
fn negative_ply_vertex_colours_are_read_as_zero_with_a_warning() {
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nproperty float red\nproperty float green\nproperty float blue\n\
               element face 1\nproperty list uchar int vertex_indices\nend_header\n\
               0 0 0 -5 0.5 0.5\n1 0 0 0.2 nan 0.3\n0 1 0 0.1 0.2 0.3\n3 0 1 2\n";
    let loaded = load_ply_bytes(
        ply.as_bytes(),
        Path::new("neg.ply"),
        &LoadOptions::default(),
    )
    .expect("loads");
    let colors = &loaded.scene.meshes[0].colors;
    assert_eq!(colors.len(), 3);
    assert!(
        colors
            .iter()
            .all(|c| c.x >= 0.0 && c.y >= 0.0 && c.z >= 0.0),
        "{colors:?}"
    );
    assert_eq!(colors[0].x, 0.0);
    assert_eq!(colors[1].y, 0.0);
    assert_eq!(colors[2].z, 0.3);
    let w: Vec<_> = loaded.warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("neg.ply") && w[0].contains("2 vertex colours"),
        "{w:?}"
    );
    let strict = LoadOptions {
        strict: true,
        ..LoadOptions::default()
    };
    assert!(load_ply_bytes(ply.as_bytes(), Path::new("neg.ply"), &strict).is_err());
}

/// A scene far smaller or farther out than the renderer's ray offsets and single-precision
/// rays suit is warned about naming the file and the fix, instead of rendering plain sky or
/// black surfaces without a word; a scene of ordinary size is not.
#[test]
fn scenes_outside_the_supported_extent_are_warned_about() {
    let tri = |scale: f32, offset: f32| {
        format!(
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
             end_header\n{o} 0 0\n{} 0 0\n{o} {s} 0\n3 0 1 2\n",
            offset + scale,
            o = offset,
            s = scale
        )
    };
    let warnings = |text: String| -> Vec<String> {
        load_ply_bytes(text.as_bytes(), Path::new("t.ply"), &LoadOptions::default())
            .expect("loads")
            .warnings
            .iter()
            .map(|w| w.to_string())
            .collect()
    };
    let w = warnings(tri(1e-4, 0.0));
    assert!(
        w.iter()
            .any(|w| w.contains("t.ply") && w.contains("scale it up")),
        "{w:?}"
    );
    let w = warnings(tri(1.0, 1e10));
    assert!(
        w.iter()
            .any(|w| w.contains("1e10") && w.contains("scale it down")),
        "{w:?}"
    );
    for (scale, offset) in [(1.0, 0.0), (0.02, 0.0), (1e6, 5e7)] {
        let w = warnings(tri(scale, offset));
        assert!(w.is_empty(), "{scale} at {offset}: {w:?}");
    }
}

/// Slips in a scene file get a message that says what is missing, not that a feature is
/// unsupported: a `<shape>` without a type is an error, a value element without a name a
/// warning; a mesh whose every face has fewer than 3 vertices is an error that says so (with
/// the OBJ line of the first), not "no faces".
#[test]
fn missing_attributes_and_short_faces_are_named_as_such() {
    let scene = |body: &str| {
        format!(
            "<scene version=\"3.0.0\"><sensor type=\"perspective\"><transform name=\"to_world\">\
             <lookat origin=\"0,0,4\" target=\"0,0,0\" up=\"0,1,0\"/></transform></sensor>\
             {body}<emitter type=\"constant\"/></scene>"
        )
    };
    let opts = LoadOptions::default();
    let e = load_mitsuba_str(&scene("<shape/>"), Path::new("s.xml"), &opts)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s.xml") && e.contains("no type attribute"),
        "{e}"
    );
    let loaded = load_mitsuba_str(
        &scene("<shape type=\"sphere\"><float value=\"2\"/></shape>"),
        Path::new("s.xml"),
        &opts,
    )
    .unwrap();
    let w: Vec<_> = loaded.warnings.iter().map(|w| w.to_string()).collect();
    assert!(w.iter().any(|w| w.contains("no name attribute")), "{w:?}");
    assert!(!w.iter().any(|w| w.contains("not supported")), "{w:?}");

    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n";
    let e = load_ply_bytes(ply.as_bytes(), Path::new("two.ply"), &opts)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("two.ply") && e.contains("3 or more vertices"),
        "{e}"
    );
    let dir = temp_dir("short-faces");
    let obj = write(&dir, "two.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2\n");
    let e = load(&obj).unwrap_err().to_string();
    assert!(
        e.contains("two.obj:5") && e.contains("3 or more vertices"),
        "{e}"
    );
}

/// A material value that is not a finite number is named as such (a NaN `Kd` used to be
/// reported as "expected 3 numbers", which it has).
#[test]
fn a_nan_material_value_is_named() {
    let dir = temp_dir("mtl-nan");
    write(&dir, "k.mtl", "newmtl m\nKd nan 0 0\n");
    let obj = write(
        &dir,
        "k.obj",
        "mtllib k.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n",
    );
    let e = load(&obj).unwrap_err().to_string();
    assert!(
        e.contains("k.mtl:2") && e.contains("\"nan\" is not a finite number"),
        "{e}"
    );
}
