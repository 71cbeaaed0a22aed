//! `lumo serve`: starts the progressive render server and its web viewer.

use crate::cli_common::{errln, outln};
use std::io::Write;
use std::net::{IpAddr, SocketAddr};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use lumo_render::camera::PinholeCamera;
use lumo_render::{PathSettings, RenderScene};
use lumo_scene::load::LoadOptions;
use lumo_server::protocol::remote::{SceneKind, SceneSource};
use lumo_server::remote::{check_token, new_token, RemoteConfig};
use lumo_server::{Hub, Integrator, ServerConfig};

use crate::arguments::parse_size;
use crate::scene_load::{load_scene_animated, names_scene_file};

/// Arguments of `lumo serve`.
#[derive(clap::Args, Debug)]
pub struct ServeArgs {
    /// Built-in scene name or scene file; the only way a scene is chosen (viewers cannot).
    #[arg(default_value = "cornell")]
    pub scene: String,
    /// TCP port (0: any free port; the line printed at start says which).
    #[arg(long, default_value_t = 8080)]
    pub port: u16,
    /// Address to listen on. The default accepts connections from this machine only.
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: IpAddr,
    /// Render threads [default: all cores].
    #[arg(long, value_parser = crate::cli_common::parse_threads)]
    pub threads: Option<usize>,
    /// Sample streams: path (camera stream), light (light stream), both (each weighted ½),
    /// bdpt (bidirectional: both streams),
    /// ppm (camera stream gathering from a photon map that grows with the samples).
    #[arg(long, value_parser = crate::integrator_arg::serve_integrators(), default_value = "path")]
    pub integrator: Integrator,
    /// Photon mapping: most photons kept in a render's map (about 72 bytes each); when full,
    /// the map starts over [default: 4194304, about 300 MB].
    #[arg(long, value_name = "N")]
    pub max_photons: Option<usize>,
    /// Image size as WIDTHxHEIGHT [default: the scene's].
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(usize, usize)>,
    /// Longest path depth (Mitsuba's convention) [default: the scene's].
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Random seed.
    #[arg(long, default_value_t = 0, value_parser = crate::cli_common::parse_seed)]
    pub seed: u32,
    /// Spectral transport for the path tracer (camera stream, filtered frames) and the light
    /// tracer (light stream): samples carry three wavelengths and are sent as the XYZ of their
    /// spectra. bdpt and ppm stay RGB (docs/spectral.md says why RGB is the default).
    #[arg(long)]
    pub spectral: bool,
    /// Throttle rendering to this many samples (camera samples plus light paths) per second,
    /// to see how the viewer behaves with a slow server.
    #[arg(long)]
    pub max_rate: Option<f64>,
    /// Play the scene's glTF animation: the server poses the scene by wall-clock time (looping
    /// over the clips) and restarts rendering at every displayed frame; the viewer's play/pause
    /// button freezes it, and a frozen frame converges as a still does (docs/animation.md).
    #[arg(long)]
    pub animate: bool,
    /// Set a Mitsuba `$name` parameter of the scene file (overrides its `<default>`);
    /// repeatable. Remote workers load the scene with the same definitions.
    #[arg(short = 'D', long = "define", value_name = "NAME=VALUE", value_parser = crate::arguments::parse_define)]
    pub defines: Vec<(String, String)>,
    /// Accept remote render workers (`lumo worker`) on --worker-bind: they load the same
    /// scene (a built-in, or the file at the same absolute path on their machine) and their
    /// samples join the viewers' stream. Prints the token they must present
    /// (docs/remote-workers.md).
    #[arg(long)]
    pub remote_workers: bool,
    /// Address and port on which remote workers connect (with --remote-workers). Workers on
    /// other machines need an address they can reach, e.g. 0.0.0.0:8081 [default:
    /// 127.0.0.1:8081].
    #[arg(long, value_name = "ADDR:PORT")]
    pub worker_bind: Option<SocketAddr>,
    /// The token remote workers must present: 32 to 64 hex digits [default: the environment
    /// variable LUMO_WORKER_TOKEN, else 128 random bits].
    #[arg(long, value_name = "HEX")]
    pub worker_token: Option<String>,
}

/// Where remote workers connect unless --worker-bind says otherwise.
const DEFAULT_WORKER_BIND: &str = "127.0.0.1:8081";

/// The remote workers' settings: the token (--worker-token, LUMO_WORKER_TOKEN or drawn) and
/// the scene as they load it (a scene file by its absolute path).
fn remote_config(args: &ServeArgs) -> Result<RemoteConfig> {
    let token = match args
        .worker_token
        .clone()
        .or_else(|| std::env::var("LUMO_WORKER_TOKEN").ok())
    {
        Some(t) => {
            check_token(&t).context("--worker-token / LUMO_WORKER_TOKEN")?;
            t
        }
        None => new_token()?,
    };
    let scene = if names_scene_file(&args.scene) {
        let path = std::path::absolute(&args.scene)
            .with_context(|| format!("scene {:?}: cannot make the path absolute", args.scene))?;
        SceneSource {
            kind: SceneKind::File,
            spec: path
                .to_str()
                .with_context(|| format!("scene path {} is not UTF-8", path.display()))?
                .to_string(),
            defines: args.defines.clone(),
        }
    } else {
        SceneSource {
            kind: SceneKind::Builtin,
            spec: args.scene.clone(),
            defines: args.defines.clone(),
        }
    };
    Ok(RemoteConfig::new(token, scene))
}

/// Runs `lumo serve` until interrupted.
pub fn run(args: ServeArgs) -> Result<()> {
    crate::cli_common::check_max_depth(args.max_depth)?;
    if let Some(r) = args.max_rate {
        if !(r.is_finite() && r > 0.0) {
            bail!("--max-rate must be a positive number of samples per second");
        }
    }
    if !args.remote_workers && (args.worker_bind.is_some() || args.worker_token.is_some()) {
        bail!("--worker-bind and --worker-token apply to --remote-workers");
    }
    let options = LoadOptions {
        defines: args.defines.clone(),
        ..Default::default()
    };
    let (mut scene, _, rig) = load_scene_animated(&args.scene, &options)?;
    let rig = match (args.animate, rig) {
        (false, _) => None,
        (true, Some(rig)) if rig.is_animated() => {
            // The first frame is t = 0, posed before the build.
            rig.pose(&mut scene, Some(0.0));
            Some(rig)
        }
        (true, _) => bail!(
            "--animate: scene {:?} has no animation (only glTF files with animation clips \
             have one, e.g. scenes/animated.gltf); drop --animate",
            scene.name
        ),
    };
    let (width, height) = args
        .size
        .unwrap_or((scene.defaults.width, scene.defaults.height));
    if width > 4096 || height > 4096 {
        bail!("--size {width}x{height}: the viewer supports at most 4096x4096");
    }
    let mut config = ServerConfig::new(width, height);
    config.threads = crate::cli_common::thread_count(args.threads).unwrap_or(0);
    config.integrator = args.integrator;
    let chosen = args.integrator;
    if let Some(why) = lumo_render::media::refusal(&scene, chosen.name(), chosen.renders_media()) {
        bail!(why);
    }
    if let Some(n) = args.max_photons {
        if n == 0 || n > crate::arguments::MAX_PHOTONS {
            bail!(
                "--max-photons {n}: expected 1..={}",
                crate::arguments::MAX_PHOTONS
            );
        }
        config.ppm.max_photons = n;
    }
    // The map grows only as photons arrive, so its bound is checked where it is asked for
    // from the start (a viewer switching to ppm later gets the same bound).
    if config.integrator == Integrator::Ppm {
        crate::cli_common::check_memory(
            crate::arguments::ppm_map_bytes(config.ppm.max_photons),
            &format!("a photon map of {} photons", config.ppm.max_photons),
            "use a smaller --max-photons",
        )?;
    }
    if args.spectral && !chosen.spectral() {
        let modes: Vec<(&str, bool)> = Integrator::ALL
            .iter()
            .map(|m| (m.name(), m.spectral()))
            .collect();
        bail!(crate::integrator_arg::spectral_refusal(&modes));
    }
    config.path = PathSettings {
        max_depth: args.max_depth.unwrap_or(scene.defaults.max_depth),
        spectral: args.spectral,
        ..Default::default()
    };
    if args.spectral {
        // Fitted once per process; here rather than in the first sample's path.
        lumo_spectrum::coefficient_table();
    }
    config.seed = args.seed;
    config.max_rate = args.max_rate;
    config.animation = rig;
    if args.remote_workers {
        config.remote = Some(remote_config(&args)?);
    }
    let name = scene.name.clone();
    let tris = scene.triangle_count();
    let start = Instant::now();
    let rs = RenderScene::new(scene)?;
    if let Some(what) = PinholeCamera::new(&rs.scene.camera, width, height).unsupported_by_splats()
    {
        errln!(
            "{name}: the scene has {what}; the viewer's light, both and bdpt modes show the \
             path tracer's camera samples instead (they project light onto a pinhole's film)"
        );
    }
    let camera = PinholeCamera::new(&rs.scene.camera, width, height);
    for part in chosen.parts() {
        if let Some(w) = part.scene_warning(&rs, &camera, &config.path) {
            errln!("{w}");
        }
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .thread_name("lumo-net")
        .enable_all()
        .build()
        .context("cannot start the network runtime")?;
    runtime.block_on(async move {
        let addr = SocketAddr::new(args.bind, args.port);
        let listener = tokio::net::TcpListener::bind(addr)
            .await
            .with_context(|| format!("cannot listen on {addr}"))?;
        let local = listener.local_addr()?;
        let hub = Hub::new(rs, config)?;
        let workers = match &hub.remote_config() {
            Some(remote) => {
                let addr = args
                    .worker_bind
                    .unwrap_or_else(|| DEFAULT_WORKER_BIND.parse().expect("a valid address"));
                let listener = tokio::net::TcpListener::bind(addr)
                    .await
                    .with_context(|| format!("--worker-bind: cannot listen on {addr}"))?;
                Some((listener.local_addr()?, remote.token.clone(), listener))
            }
            None => None,
        };
        errln!(
            "{name}: {tris} triangles (ready in {:.0} ms), {width}x{height}, {} render threads",
            start.elapsed().as_secs_f64() * 1e3,
            hub.threads()
        );
        if !args.bind.is_loopback() {
            errln!(
                "warning: listening on {} — reachable from other machines",
                args.bind
            );
        }
        outln!("open {}", viewer_url(local));
        if let Some((addr, token, listener)) = workers {
            if !addr.ip().is_loopback() {
                errln!(
                    "warning: remote workers connect on {addr} — reachable from other machines; \
                     the token is their only check and the connection is not encrypted"
                );
            }
            outln!("workers: lumo worker --hub {addr} --token {token}");
            let hub = hub.clone();
            tokio::spawn(async move {
                if let Err(e) = lumo_server::remote::serve_workers(listener, hub).await {
                    errln!("remote workers: {e}");
                }
            });
        }
        std::io::stdout().flush().ok();
        lumo_server::serve(listener, hub)
            .await
            .context("server stopped")
    })
}

/// The URL a browser on this machine opens for a server listening on `local`: an unspecified
/// address (`0.0.0.0`, `::`) becomes the loopback of its family, and an IPv6 host is
/// bracketed (`--bind ::` printed `http://[127.0.0.1]:PORT`, which no browser opens).
fn viewer_url(local: std::net::SocketAddr) -> String {
    use std::net::{IpAddr, Ipv4Addr, Ipv6Addr};
    let ip = match local.ip() {
        IpAddr::V4(ip) if ip.is_unspecified() => IpAddr::V4(Ipv4Addr::LOCALHOST),
        IpAddr::V6(ip) if ip.is_unspecified() => IpAddr::V6(Ipv6Addr::LOCALHOST),
        ip => ip,
    };
    match ip {
        IpAddr::V4(ip) => format!("http://{ip}:{}", local.port()),
        IpAddr::V6(ip) => format!("http://[{ip}]:{}", local.port()),
    }
}

#[cfg(test)]
mod tests {
    use super::viewer_url;

    #[test]
    fn the_printed_url_opens_in_a_browser() {
        let url = |a: &str| viewer_url(a.parse().unwrap());
        assert_eq!(url("0.0.0.0:8080"), "http://127.0.0.1:8080");
        assert_eq!(url("[::]:8080"), "http://[::1]:8080");
        assert_eq!(url("[::1]:9"), "http://[::1]:9");
        assert_eq!(url("[fe80::1]:9"), "http://[fe80::1]:9");
        assert_eq!(url("192.168.1.5:80"), "http://192.168.1.5:80");
    }
}
