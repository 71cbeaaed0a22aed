//! Scene edits over real sockets: a pick names what is under a pixel, an EDIT changes the
//! rendered image (a new epoch every viewer hears of), and edits that do not fit the scene are
//! refused with a reason while the connection stays up.

use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use glam::Vec3;
use lumo_render::RenderScene;
use lumo_scene::builtin_scene;
use lumo_server::protocol::client::{decode_server, ServerMessage};
use lumo_server::protocol::{
    Edit, EditOp, ErrorCode, Integrator, Mode, Params, Pick, PickHit, PickTarget,
};
use lumo_server::scene_edit::EditTargets;
use lumo_server::{Hub, ServerConfig};
use tokio::net::TcpStream;
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::{connect_async, MaybeTlsStream, WebSocketStream};

type Ws = WebSocketStream<MaybeTlsStream<TcpStream>>;

const SIZE: usize = 32;

async fn start() -> Ws {
    let rs = RenderScene::new(builtin_scene("cornell").expect("builtin")).expect("scene");
    let mut config = ServerConfig::new(SIZE, SIZE);
    config.threads = 2;
    let hub = Hub::new(rs, config).expect("hub");
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .expect("bind");
    let addr = listener.local_addr().expect("addr");
    tokio::spawn(lumo_server::serve(listener, hub));
    connect_async(format!("ws://{addr}/ws"))
        .await
        .expect("connect")
        .0
}

/// Reads until `pred` matches, failing the test after 20 s.
async fn until(ws: &mut Ws, mut pred: impl FnMut(&ServerMessage) -> bool) -> ServerMessage {
    loop {
        let m = tokio::time::timeout(Duration::from_secs(20), ws.next())
            .await
            .expect("timed out")
            .expect("closed")
            .expect("ws error");
        if let Message::Binary(b) = m {
            let m = decode_server(&b).expect("decodable");
            if pred(&m) {
                return m;
            }
        }
    }
}

async fn send(ws: &mut Ws, bytes: Vec<u8>) {
    ws.send(Message::Binary(bytes.into())).await.expect("send");
}

/// Waits for the next epoch's CAMERA, then for a frame of that epoch averaging at least 8
/// one-sample frames; returns its luminance (XYZ's Y) per pixel.
async fn next_epoch_frame(ws: &mut Ws) -> Vec<f32> {
    let ServerMessage::Camera(c) = until(ws, |m| matches!(m, ServerMessage::Camera(_))).await
    else {
        unreachable!()
    };
    let epoch = c.epoch;
    match until(
        ws,
        |m| matches!(m, ServerMessage::Frame(f, _) if f.epoch == epoch && f.frames >= 8),
    )
    .await
    {
        ServerMessage::Frame(_, px) => px.iter().map(|p| p[1]).collect(),
        _ => unreachable!(),
    }
}

async fn pick(ws: &mut Ws, request: u32, uv: [f32; 2]) -> PickHit {
    let p = Pick {
        request,
        uv,
        hit: PickHit::nothing(),
    };
    send(ws, p.write()).await;
    match until(
        ws,
        |m| matches!(m, ServerMessage::Pick(p) if p.request == request),
    )
    .await
    {
        ServerMessage::Pick(p) => p.hit,
        _ => unreachable!(),
    }
}

fn mean(v: &[f32]) -> f32 {
    v.iter().sum::<f32>() / v.len() as f32
}

/// Pick the tall box, recolour it, move it, switch the ceiling light off: each edit comes back
/// as EDIT and a new epoch whose frames differ from the last in the way the edit says.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn edits_from_a_viewer_change_the_image() {
    let mut ws = start().await;
    let params = Params {
        integrator: Integrator::Path,
        mode: Mode::Atrous,
    };
    send(&mut ws, params.write()).await;
    let before = next_epoch_frame(&mut ws).await;

    // The tall box stands left of the centre in the Cornell box.
    let uv = [0.35, 0.55];
    let hit = pick(&mut ws, 1, uv).await;
    assert_eq!(hit.target, PickTarget::Object, "{hit:?}");
    assert!(hit.has_color && hit.name.contains("white"), "{hit:?}");
    let pixel = (uv[1] * SIZE as f32) as usize * SIZE + (uv[0] * SIZE as f32) as usize;

    // Base colour: the white box turns dark; the picked pixel darkens, the image as a whole
    // less (the box is a small part of it).
    let dark = Edit {
        op: EditOp::BaseColor,
        index: hit.material,
        value: Vec3::splat(0.05),
    };
    send(&mut ws, dark.write()).await;
    assert_eq!(
        until(&mut ws, |m| matches!(m, ServerMessage::Edit(_))).await,
        ServerMessage::Edit(dark)
    );
    let darker = next_epoch_frame(&mut ws).await;
    assert!(
        darker[pixel] < 0.3 * before[pixel],
        "picked pixel {} → {}",
        before[pixel],
        darker[pixel]
    );
    assert!(mean(&darker) < mean(&before), "the image darkens");

    // Move: the instance leaves the pixel, so a pick there finds something else, farther.
    let moved = Edit {
        op: EditOp::MoveInstance,
        index: hit.index,
        value: hit.position + Vec3::new(0.0, 5.0, 0.0),
    };
    send(&mut ws, moved.write()).await;
    next_epoch_frame(&mut ws).await;
    let after = pick(&mut ws, 2, uv).await;
    assert!(
        after.index != hit.index && after.point.z < hit.point.z,
        "after the move the pixel shows {after:?}, before {hit:?}"
    );

    // The ceiling light's emission to zero: nothing lights the box any more.
    let mut light = PickHit::nothing();
    for (i, v) in (0..20).map(|i| (i, 0.01 * i as f32)) {
        light = pick(&mut ws, 10 + i, [0.5, v]).await;
        if light.emission.max_element() > 0.0 {
            break;
        }
    }
    assert!(light.emission.max_element() > 1.0, "{light:?}");
    send(
        &mut ws,
        Edit {
            op: EditOp::Emission,
            index: light.material,
            value: Vec3::ZERO,
        }
        .write(),
    )
    .await;
    let dark_room = next_epoch_frame(&mut ws).await;
    assert!(mean(&dark_room) < 1e-3, "mean {}", mean(&dark_room));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn edits_that_do_not_fit_the_scene_are_refused() {
    let mut ws = start().await;
    let refused = [
        (EditOp::MoveInstance, 99, "instance 99 does not exist"),
        (
            EditOp::MoveLight,
            0,
            "light 0 does not exist (the scene has 0)",
        ),
        (EditOp::BaseColor, 1000, "material 1000 does not exist"),
    ];
    for (op, index, why) in refused {
        let e = Edit {
            op,
            index,
            value: Vec3::splat(0.5),
        };
        send(&mut ws, e.write()).await;
        match until(&mut ws, |m| matches!(m, ServerMessage::Error(_))).await {
            ServerMessage::Error(err) => {
                assert_eq!(err.code, ErrorCode::InvalidValue as u16);
                assert!(err.message.contains(why), "{op:?}: {}", err.message);
            }
            _ => unreachable!(),
        }
    }
    // Still connected: a pick is answered.
    assert_ne!(
        pick(&mut ws, 4, [0.5, 0.5]).await.target,
        PickTarget::Nothing
    );
}

/// The kinds an edit needs: a glass has no base colour, an environment no intensity or
/// position.
#[test]
fn edit_targets_know_what_each_part_of_the_scene_takes() {
    let scene = builtin_scene("cornell-spheres").expect("builtin");
    let glass = scene
        .materials
        .iter()
        .position(|m| matches!(m.bsdf, lumo_scene::BsdfSpec::Dielectric { .. }))
        .expect("a glass sphere");
    let t = EditTargets::of(&RenderScene::new(scene).expect("scene"));
    let edit = |op, index| Edit {
        op,
        index,
        value: Vec3::splat(0.5),
    };
    let err = t
        .check(&edit(EditOp::BaseColor, glass as u32))
        .expect_err("glass");
    assert!(err.message.contains("no base colour"), "{}", err.message);
    assert!(t.check(&edit(EditOp::Emission, glass as u32)).is_ok());
    assert!(t.check(&edit(EditOp::MoveInstance, 0)).is_ok());
}

/// A point light has no surface: a click within a few pixels of where it projects picks it,
/// and moving it or changing its intensity reaches the scene's light table.
#[test]
fn a_point_light_is_picked_near_its_projection_and_edited() {
    use lumo_render::camera::PinholeCamera;
    use lumo_server::scene_edit::{apply, pick};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/animated.gltf");
    let loaded = lumo_scene::load::load_scene(&path, &Default::default()).expect("load");
    let mut rs = RenderScene::new(loaded.scene).expect("scene");
    let (index, position) = rs
        .scene
        .lights
        .iter()
        .enumerate()
        .find_map(|(i, l)| match l {
            lumo_scene::Light::Point { position, .. } => Some((i, *position)),
            _ => None,
        })
        .expect("a point light");
    let camera = rs.scene.camera.clone();
    let (w, h) = (160, 120);
    let Some((at, _)) = PinholeCamera::new(&camera, w, h).project_point(position) else {
        panic!("the light is in view");
    };
    let uv = |dx: f32| [(at.x + dx) / w as f32, at.y / h as f32];
    let hit = pick(&rs, &camera, w, h, uv(5.0));
    assert_eq!(
        (hit.target, hit.index),
        (PickTarget::Light, index as u32),
        "{hit:?}"
    );
    assert_eq!(hit.position, position);
    assert!(hit.name.contains("point light"), "{}", hit.name);
    assert_ne!(pick(&rs, &camera, w, h, uv(40.0)).target, PickTarget::Light);
    let t = EditTargets::of(&rs);
    let moved = position + Vec3::new(0.5, 0.0, 0.0);
    let edits = [
        Edit {
            op: EditOp::MoveLight,
            index: index as u32,
            value: moved,
        },
        Edit {
            op: EditOp::LightIntensity,
            index: index as u32,
            value: Vec3::new(1.0, 2.0, 3.0),
        },
    ];
    for e in &edits {
        t.check(e).expect("valid");
    }
    apply(&mut rs, &edits).expect("applied");
    match &rs.scene.lights[index] {
        lumo_scene::Light::Point {
            position,
            intensity,
            range: None,
        } => assert_eq!((*position, *intensity), (moved, Vec3::new(1.0, 2.0, 3.0))),
        l => panic!("{l:?}"),
    }
}
