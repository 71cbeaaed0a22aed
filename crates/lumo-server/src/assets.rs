//! The viewer's files (web/), embedded in the binary so `lumo serve` needs nothing on disk.

/// One embedded file.
#[derive(Clone, Copy, Debug)]
pub struct Asset {
    /// URL path.
    pub path: &'static str,
    /// MIME type.
    pub content_type: &'static str,
    /// Contents.
    pub body: &'static str,
}

macro_rules! web {
    ($path:literal, $ty:expr) => {
        Asset {
            path: concat!("/", $path),
            content_type: $ty,
            body: include_str!(concat!("../../../web/", $path)),
        }
    };
}

const JS: &str = "text/javascript; charset=utf-8";
const GLSL: &str = "text/plain; charset=utf-8";

/// Every file of the viewer.
pub const ASSETS: &[Asset] = &[
    web!("index.html", "text/html; charset=utf-8"),
    web!("style.css", "text/css; charset=utf-8"),
    web!("main.js", JS),
    web!("protocol.js", JS),
    web!("protocol_layout.js", JS),
    web!("gl.js", JS),
    web!("stream.js", JS),
    web!("display.js", JS),
    web!("navigation.js", JS),
    web!("edit.js", JS),
    web!("ui.js", JS),
    web!("shaders/quad.vert", GLSL),
    web!("shaders/splat.vert", GLSL),
    web!("shaders/splat.frag", GLSL),
    web!("shaders/variance.frag", GLSL),
    web!("shaders/mip.frag", GLSL),
    web!("shaders/display.frag", GLSL),
];

/// The asset for a URL path (`/` is the page).
pub fn find(path: &str) -> Option<&'static Asset> {
    let path = if path == "/" { "/index.html" } else { path };
    ASSETS.iter().find(|a| a.path == path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn page_and_modules_are_embedded() {
        let page = find("/").expect("index");
        assert!(page.body.contains("main.js"));
        assert!(find("/shaders/display.frag").is_some());
        assert!(find("/../Cargo.toml").is_none());
        for a in ASSETS {
            assert!(!a.body.is_empty(), "{} is empty", a.path);
        }
    }
}
