//! A glTF file built in a test: binary arrays in an external .bin, one view and accessor each.

use std::path::{Path, PathBuf};

use super::write;

/// A glTF file under construction: data in an external .bin, one view and accessor per array.
#[derive(Default)]
pub struct Builder {
    bin: Vec<u8>,
    views: Vec<String>,
    accessors: Vec<String>,
}

impl Builder {
    /// One view over `bytes` and an accessor of `count` elements over it (`extra`: more
    /// accessor fields, starting with a comma).
    pub fn add(
        &mut self,
        bytes: &[u8],
        count: usize,
        ty: &str,
        component: u32,
        extra: &str,
    ) -> usize {
        self.add_strided(bytes, None, count, ty, component, extra)
    }

    /// [`Builder::add`] with the view's byteStride.
    pub fn add_strided(
        &mut self,
        bytes: &[u8],
        stride: Option<usize>,
        count: usize,
        ty: &str,
        component: u32,
        extra: &str,
    ) -> usize {
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        let stride = stride.map_or(String::new(), |s| format!(r#", "byteStride": {s}"#));
        self.views.push(format!(
            r#"{{"buffer": 0, "byteOffset": {offset}, "byteLength": {}{stride}}}"#,
            bytes.len()
        ));
        self.accessors.push(format!(
            r#"{{"bufferView": {}, "componentType": {component}, "count": {count}, "type": "{ty}"{extra}}}"#,
            self.views.len() - 1
        ));
        self.accessors.len() - 1
    }

    /// Float data of type `ty` (bounds added to finite VEC3s, as POSITION needs).
    pub fn floats(&mut self, v: &[f32], ty: &str) -> usize {
        let comps = match ty {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            "MAT4" => 16,
            _ => panic!("{ty}"),
        };
        // glTF requires bounds on POSITION; only finite ones can be written in JSON.
        let extra = if comps == 3 && v.iter().all(|x| x.is_finite()) {
            let bound = |f: fn(f32, f32) -> f32| {
                (0..3)
                    .map(|c| {
                        let x = v.iter().skip(c).step_by(3).copied().reduce(f).unwrap();
                        format!("{x:?}")
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            format!(
                r#", "min": [{}], "max": [{}]"#,
                bound(f32::min),
                bound(f32::max)
            )
        } else {
            String::new()
        };
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.add(&bytes, v.len() / comps, ty, 5126, &extra)
    }

    /// Unsigned shorts of type `ty` (SCALAR or VEC4).
    pub fn u16s(&mut self, v: &[u16], ty: &str) -> usize {
        let comps = if ty == "VEC4" { 4 } else { 1 };
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.add(&bytes, v.len() / comps, ty, 5123, "")
    }

    /// A sparse float accessor of `count` elements of type `ty`: over the float accessor
    /// `base`'s view (or zeros with `None`), the elements at `indices` (unsigned shorts)
    /// replaced by `values` (`extra`: more accessor fields, starting with a comma).
    pub fn sparse(
        &mut self,
        base: Option<usize>,
        (count, ty): (usize, &str),
        indices: &[u16],
        values: &[f32],
        extra: &str,
    ) -> usize {
        let view = |b: &mut Self, bytes: Vec<u8>| {
            let offset = b.bin.len();
            b.bin.extend_from_slice(&bytes);
            b.bin.resize(b.bin.len().next_multiple_of(4), 0);
            b.views.push(format!(
                r#"{{"buffer": 0, "byteOffset": {offset}, "byteLength": {}}}"#,
                bytes.len()
            ));
            b.views.len() - 1
        };
        let iv = view(self, indices.iter().flat_map(|x| x.to_le_bytes()).collect());
        let vv = view(self, values.iter().flat_map(|x| x.to_le_bytes()).collect());
        let base_view = base.map_or(String::new(), |a| {
            // The base accessor's view is the one `add` made with it.
            format!(r#""bufferView": {}, "#, self.view_of(a))
        });
        self.accessors.push(format!(
            r#"{{{base_view}"componentType": 5126, "count": {count}, "type": "{ty}",
               "sparse": {{"count": {}, "indices": {{"bufferView": {iv}, "componentType": 5123}},
                           "values": {{"bufferView": {vv}}}}}{extra}}}"#,
            indices.len()
        ));
        self.accessors.len() - 1
    }

    /// The view accessor `a` reads.
    fn view_of(&self, a: usize) -> usize {
        let s = &self.accessors[a];
        let rest = &s[s.find("\"bufferView\": ").expect("a view") + 14..];
        rest[..rest.find(',').expect("more fields")]
            .parse()
            .expect("a number")
    }

    /// Writes `dir/name` (and its .bin) with `rest` (nodes, meshes, ...) at the top level.
    pub fn write(&self, dir: &Path, name: &str, rest: &str) -> PathBuf {
        let bin = format!("{name}.bin");
        write(dir, &bin, &self.bin);
        let json = format!(
            r#"{{"asset": {{"version": "2.0"}}, "scene": 0,
            "buffers": [{{"uri": "{bin}", "byteLength": {}}}],
            "bufferViews": [{}], "accessors": [{}], {rest}}}"#,
            self.bin.len(),
            self.views.join(", "),
            self.accessors.join(", ")
        );
        write(dir, name, json)
    }
}
