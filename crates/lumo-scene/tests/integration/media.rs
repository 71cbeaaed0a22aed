//! Mitsuba media: homogeneous and grid media, phase functions, shape interfaces, the sensor's
//! medium and the null BSDF; and the errors for media that cannot be rendered.

use std::path::{Path, PathBuf};

use glam::Vec3;
use lumo_scene::load::{load_mitsuba_str, load_scene, LoadOptions};
use lumo_scene::media::Density;
use lumo_scene::{Boundary, MediumInterface, PhaseFunction, Scene};

fn load(body: &str) -> Result<Scene, String> {
    let xml = format!(r#"<scene version="3.0.0">{body}</scene>"#);
    load_mitsuba_str(&xml, Path::new("media.xml"), &LoadOptions::default())
        .map(|l| l.scene)
        .map_err(|e| e.to_string())
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lumo-media-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn vol_bytes(res: [i32; 3], values: &[f32]) -> Vec<u8> {
    let mut b = b"VOL\x03".to_vec();
    for v in [1, res[0], res[1], res[2], 1] {
        b.extend(v.to_le_bytes());
    }
    for v in [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0].iter().chain(values) {
        b.extend(v.to_le_bytes());
    }
    b
}

#[test]
fn media_interfaces_camera_medium_and_null_boundaries_load() {
    let scene = load(
        r#"<medium type="homogeneous" id="fog">
             <float name="sigma_t" value="0.5"/><rgb name="albedo" value="0.9, 0.8, 0.7"/>
             <float name="scale" value="2"/><phase type="hg"><float name="g" value="0.4"/></phase>
           </medium>
           <sensor type="perspective"><ref id="fog"/></sensor>
           <shape type="sphere"><bsdf type="null"/><ref name="interior" id="fog"/></shape>
           <shape type="cube"><bsdf type="dielectric"/>
             <medium type="homogeneous" name="interior">
               <rgb name="sigma_a" value="0.1, 0.2, 0.3"/><rgb name="sigma_s" value="0.9, 0.8, 0.7"/>
             </medium>
             <ref name="exterior" id="fog"/>
           </shape>
           <shape type="rectangle"/>
           <emitter type="constant"/>"#,
    )
    .unwrap();
    let m = &scene.media;
    assert_eq!(m.media.len(), 2);
    assert_eq!(m.camera, Some(0));
    assert_eq!(m.media[0].sigma_t, Vec3::ONE);
    assert_eq!(m.media[0].albedo, Vec3::new(0.9, 0.8, 0.7));
    assert_eq!(m.media[0].phase, PhaseFunction::HenyeyGreenstein { g: 0.4 });
    assert_eq!(m.media[1].sigma_t, Vec3::ONE);
    assert!(
        (m.media[1].albedo - Vec3::new(0.9, 0.8, 0.7))
            .abs()
            .max_element()
            < 1e-6
    );
    assert_eq!(
        m.boundary(0),
        Boundary {
            null: true,
            interface: Some(MediumInterface {
                interior: Some(0),
                exterior: None
            })
        }
    );
    assert_eq!(
        m.boundary(1),
        Boundary {
            null: false,
            interface: Some(MediumInterface {
                interior: Some(1),
                exterior: Some(0)
            })
        }
    );
    assert_eq!(m.boundary(2), Boundary::default());
    assert!(m.is_active());
}

#[test]
fn a_gridvolume_loads_and_bad_grids_name_the_file() {
    let dir = temp_dir("grid");
    std::fs::write(
        dir.join("ok.vol"),
        vol_bytes([2, 2, 2], &[0.0, 1.0, 2.0, 3.0, 0.5, 0.5, 0.5, 0.5]),
    )
    .unwrap();
    std::fs::write(dir.join("lying.vol"), vol_bytes([64, 64, 64], &[1.0; 8])).unwrap();
    std::fs::write(dir.join("nan.vol"), vol_bytes([2, 1, 1], &[1.0, f32::NAN])).unwrap();
    std::fs::write(
        dir.join("text.vol"),
        "this is not a grid, only some words that are long enough",
    )
    .unwrap();
    let scene_with = |file: &str| {
        let path = dir.join(format!("{file}.xml"));
        std::fs::write(
            &path,
            format!(
                r#"<scene version="3.0.0"><medium type="heterogeneous" id="smoke">
                 <volume name="sigma_t" type="gridvolume"><string name="filename" value="{file}"/>
                 <transform name="to_world"><scale value="2"/></transform></volume>
                 <float name="scale" value="4"/><float name="albedo" value="0.5"/></medium>
                 <shape type="cube"><bsdf type="null"/><ref name="interior" id="smoke"/></shape>
                 <emitter type="constant"/></scene>"#
            ),
        )
        .unwrap();
        load_scene(&path, &LoadOptions::default()).map_err(|e| e.to_string())
    };
    let scene = scene_with("ok.vol").unwrap().scene;
    let m = &scene.media.media[0];
    assert_eq!(m.sigma_t, Vec3::splat(4.0));
    assert_eq!(m.max_sigma_t(), Vec3::splat(12.0));
    let Density::Grid { grid, to_local } = &m.density else {
        panic!("not a grid")
    };
    assert_eq!(grid.resolution(), [2, 2, 2]);
    assert_eq!(to_local.transform_point3(Vec3::splat(2.0)), Vec3::ONE);
    for (file, says) in [
        ("lying.vol", "truncated"),
        ("nan.vol", "voxel (1, 0, 0) has density NaN"),
        ("text.vol", "not a Mitsuba grid"),
        ("missing.vol", "cannot read"),
    ] {
        let e = scene_with(file).unwrap_err();
        assert!(e.contains(file) && e.contains(says), "{file}: {e}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn media_that_cannot_be_rendered_are_refused() {
    let medium = |params: &str| {
        load(&format!(
            r#"<medium type="homogeneous" id="m">{params}</medium><emitter type="constant"/>"#
        ))
        .unwrap_err()
    };
    let e = medium(r#"<float name="sigma_t" value="inf"/>"#);
    assert!(e.contains("sigma_t") && e.contains("not finite"), "{e}");
    let e = medium(r#"<float name="albedo" value="1.5"/>"#);
    assert!(e.contains("albedo") && e.contains("[0, 1]"), "{e}");
    let e = medium(r#"<phase type="hg"><float name="g" value="1"/></phase>"#);
    assert!(e.contains("g = 1"), "{e}");
    let e = load(r#"<medium type="swirly" id="m"/>"#).unwrap_err();
    assert!(e.contains("swirly") && e.contains("homogeneous"), "{e}");
    let e = load(r#"<shape type="cube"><medium type="homogeneous" name="inside"/></shape>"#)
        .unwrap_err();
    assert!(e.contains("interior"), "{e}");
    let e = load(r#"<shape type="cube"><bsdf type="null"/><emitter type="area"/></shape>"#)
        .unwrap_err();
    assert!(e.contains("null BSDF"), "{e}");
}

/// `<spectrum>` pairs on a medium are kept for spectral rendering (RGB rendering reads their
/// colours); before, `--spectral` upsampled those colours and a chromatic fog's blue read 2.5 %
/// bright against Mitsuba's llvm_ad_spectral (suite scene spectral_media_chromatic_fog).
#[test]
fn medium_spectra_are_kept_and_spectral_absorption_pairs_warned_about() {
    let scene = load(
        r#"<medium type="homogeneous" id="fog">
             <spectrum name="sigma_t" value="400:0.9, 700:0.1"/>
             <spectrum name="albedo" value="400:0.5, 700:0.9"/>
             <float name="scale" value="2"/>
           </medium>
           <sensor type="perspective"><ref id="fog"/></sensor>
           <emitter type="constant"/>"#,
    )
    .unwrap();
    let s = &scene.media.media[0].spectra;
    let (t, a) = (s.sigma_t.as_ref().unwrap(), s.albedo.as_ref().unwrap());
    assert_eq!((t.eval(400.0), t.eval(550.0)), (0.9, 0.5));
    assert_eq!(s.sigma_t_scale, 2.0);
    assert!((a.eval(550.0) - 0.7).abs() < 1e-6);
    let rgb = load(
        r#"<medium type="homogeneous" id="fog"><float name="sigma_t" value="0.5"/></medium>
           <sensor type="perspective"><ref id="fog"/></sensor>"#,
    )
    .unwrap();
    assert!(rgb.media.media[0].spectra.sigma_t.is_none());
    assert!(rgb.media.media[0].spectra.albedo.is_none());
    let xml = r#"<scene version="3.0.0"><medium type="homogeneous" id="fog">
                   <spectrum name="sigma_a" value="400:0.1, 700:0.3"/>
                 </medium><sensor type="perspective"><ref id="fog"/></sensor></scene>"#;
    let strict = LoadOptions {
        strict: true,
        ..LoadOptions::default()
    };
    let Err(e) = load_mitsuba_str(xml, Path::new("media.xml"), &strict) else {
        panic!("strict mode refuses the approximation");
    };
    let e = e.to_string();
    assert!(
        e.contains("sigma_a / sigma_s given as spectra") && e.contains("sigma_t and albedo"),
        "{e}"
    );
}
