//! Writes the field tables out for the other two readers of the protocol: the ES module
//! `web/protocol_layout.js`, from which `web/protocol.js` takes every offset and code, and
//! the message tables of docs/protocol.md (between `<!-- layout NAME -->` and
//! `<!-- /layout -->`; `NAME` is a message, a record or `TYPES`, the list of message types). The integration test `protocol_layout` fails when either committed
//! file differs from these; `LUMO_BLESS=1` rewrites them.

use std::fmt::Write;

use super::layout::{Count, Direction, Field, FieldType, Layout, WireEnum};
use super::remote::WORKER_MESSAGES;
use super::{ENUMS, HEADER_BYTES, MESSAGES, RECORDS, VERSION};

/// `s` as a single-quoted JavaScript string.
fn js_str(s: &str) -> String {
    format!("'{}'", s.replace('\\', "\\\\").replace('\'', "\\'"))
}

fn js_field(out: &mut String, f: &Field) {
    let count = match f.count {
        Count::Fixed(n) => n.to_string(),
        Count::Product(factor, fields) => {
            let names: Vec<String> = fields.iter().map(|n| js_str(n)).collect();
            format!("{{ factor: {factor}, fields: [{}] }}", names.join(", "))
        }
    };
    let extra = match f.ty {
        FieldType::Enum(e) => format!(", enum: {}", js_str(e.name)),
        FieldType::Record(r) => format!(", record: {}", js_str(r.name)),
        _ => String::new(),
    };
    let _ = writeln!(
        out,
        "      {}: {{ offset: {}, type: {}{extra}, bytes: {}, count: {count} }},",
        f.name,
        f.offset,
        js_str(f.ty.name()),
        f.ty.bytes(),
    );
}

fn js_layout(out: &mut String, l: &Layout, message: bool) {
    let _ = writeln!(out, "  {}: {{", l.name);
    if message {
        let direction = match l.direction {
            Direction::ToViewer => "toViewer",
            Direction::Both => "both",
            Direction::ToWorker => "toWorker",
            Direction::FromWorker => "fromWorker",
        };
        let _ = writeln!(out, "    kind: {:#04x},", l.kind);
        let _ = writeln!(out, "    direction: {},", js_str(direction));
    }
    let _ = writeln!(out, "    bytes: {},", l.bytes);
    let _ = writeln!(out, "    fields: {{");
    for f in l.fields {
        js_field(out, f);
    }
    let _ = writeln!(out, "    }},");
    let _ = writeln!(out, "  }},");
}

/// The contents of `web/protocol_layout.js`.
pub fn javascript() -> String {
    let mut out = String::new();
    out.push_str(
        "// The wire layout of docs/protocol.md as data, GENERATED from the Rust message tables\n\
         // (crates/lumo-server/src/protocol/): do not edit. After changing a table, rewrite it with\n\
         // LUMO_BLESS=1 cargo test --release -p lumo-server --test integration protocol_layout\n\
         //\n\
         // MESSAGES: per message, its type byte, fixed size in bytes (header included) and fields:\n\
         // byte offset from the start of the message, element type and bytes, and count (a number,\n\
         // or factor × the product of earlier fields for the variable tail). RECORDS: the common\n\
         // header and the packed sample. ENUMS: wire codes, names and display labels.\n\n",
    );
    let _ = writeln!(out, "export const VERSION = {VERSION};");
    let _ = writeln!(out, "export const HEADER_BYTES = {HEADER_BYTES};\n");
    out.push_str("export const ENUMS = {\n");
    for e in ENUMS {
        js_enum(&mut out, e);
    }
    out.push_str("};\n\nexport const RECORDS = {\n");
    for r in RECORDS {
        js_layout(&mut out, r, false);
    }
    out.push_str("};\n\nexport const MESSAGES = {\n");
    for m in MESSAGES {
        js_layout(&mut out, m, true);
    }
    out.push_str("};\n");
    out
}

fn js_enum(out: &mut String, e: &WireEnum) {
    let _ = writeln!(out, "  {}: {{", e.name);
    let _ = writeln!(out, "    bytes: {},", e.bytes);
    let _ = writeln!(out, "    values: [");
    for v in e.variants {
        let _ = writeln!(
            out,
            "      {{ code: {}, name: {}, label: {} }},",
            v.code,
            js_str(v.name),
            js_str(v.label)
        );
    }
    let _ = writeln!(out, "    ],");
    let _ = writeln!(out, "  }},");
}

/// The number of elements of a variable count, as docs write it: `12·count`.
fn product(factor: usize, fields: &[&str]) -> String {
    let mut parts: Vec<String> = Vec::new();
    if factor != 1 {
        parts.push(factor.to_string());
    }
    parts.extend(fields.iter().map(|f| f.to_string()));
    parts.join("·")
}

/// The type column of a field in docs/protocol.md.
fn md_type(f: &Field) -> String {
    let one = |t: FieldType| match t {
        FieldType::Enum(e) => format!("u{}", 8 * e.bytes),
        FieldType::Bool => "u8".into(),
        FieldType::Unorm16 => "u16".into(),
        t => t.name().into(),
    };
    match (f.count, f.ty) {
        (Count::Fixed(n), FieldType::Reserved) => format!("{n} bytes"),
        (Count::Fixed(1), t) => one(t),
        (Count::Fixed(n), t) => format!("{n} × {}", one(t)),
        (Count::Product(k, fs), FieldType::Utf8) => format!("{} bytes", product(k, fs)),
        (Count::Product(k, fs), FieldType::Record(r)) => {
            format!("{} × {} bytes", product(k, fs), r.bytes)
        }
        (Count::Product(k, fs), t) => format!("{} × {}", product(k, fs), one(t)),
    }
}

/// The field column: name and meaning (when it says more than the name), with an
/// enumeration's codes.
fn md_field(f: &Field) -> String {
    let mut s = format!("`{}`", f.name);
    let mut meaning = if f.doc == f.name {
        String::new()
    } else {
        f.doc.to_string()
    };
    if let FieldType::Enum(e) = f.ty {
        let codes: Vec<String> = e
            .variants
            .iter()
            .map(|v| format!("{} {}", v.code, v.label))
            .collect();
        let codes = codes.join(", ");
        meaning = if meaning.is_empty() {
            codes
        } else {
            format!("{meaning} ({codes})")
        };
    }
    if let FieldType::Record(r) = f.ty {
        meaning = format!("{} records (below)", r.name);
    }
    if !meaning.is_empty() {
        let _ = write!(s, ": {meaning}");
    }
    s
}

/// The generated block of docs/protocol.md for a message (heading and table) or a record
/// (table).
pub fn markdown(l: &Layout) -> String {
    let mut out = String::new();
    if l.kind != 0 {
        let size = match l.tail() {
            Some(Field {
                count: Count::Product(k, fs),
                ty,
                ..
            }) => format!("{} + {}", l.bytes, product(k * ty.bytes(), fs)),
            _ => l.bytes.to_string(),
        };
        let direction = direction_words(l.direction);
        let _ = writeln!(
            out,
            "### {} ({:#04x}), {size} bytes, {direction}\n",
            l.name, l.kind
        );
    }
    out.push_str("| offset | type | field |\n| --- | --- | --- |\n");
    for f in l.fields {
        let _ = writeln!(out, "| {} | {} | {} |", f.offset, md_type(f), md_field(f));
    }
    out
}

/// The table of message types (the `TYPES` block of docs/protocol.md).
pub fn markdown_types() -> String {
    let mut out = String::from("| type | name | direction |\n| --- | --- | --- |\n");
    for m in MESSAGES {
        let direction = match m.direction {
            Direction::Both => "both",
            d => direction_words(d),
        };
        let _ = writeln!(out, "| {:#04x} | {} | {direction} |", m.kind, m.name);
    }
    out
}

/// The table of the remote-worker messages (the `WORKER_TYPES` block of docs/protocol.md).
pub fn markdown_worker_types() -> String {
    let mut out = String::from("| type | name | direction |\n| --- | --- | --- |\n");
    for m in WORKER_MESSAGES {
        let _ = writeln!(
            out,
            "| {:#04x} | {} | {} |",
            m.kind,
            m.name,
            direction_words(m.direction)
        );
    }
    out
}

/// Who sends a message, in the docs' words.
fn direction_words(d: Direction) -> &'static str {
    match d {
        Direction::ToViewer => "server → viewer",
        Direction::Both => "both ways",
        Direction::ToWorker => "hub → worker",
        Direction::FromWorker => "worker → hub",
    }
}

/// `doc` with every generated block replaced by what the tables say now; an error names a
/// message or record without a block, or a block of an unknown name.
pub fn update_markdown(doc: &str) -> Result<String, String> {
    const OPEN: &str = "<!-- layout ";
    const CLOSE: &str = "<!-- /layout -->";
    let all: Vec<&Layout> = RECORDS
        .iter()
        .chain(MESSAGES)
        .chain(WORKER_MESSAGES)
        .copied()
        .collect();
    let mut out = String::new();
    let mut rest = doc;
    let mut seen = Vec::new();
    while let Some(start) = rest.find(OPEN) {
        let after = &rest[start + OPEN.len()..];
        let name_end = after.find(" -->").ok_or("unterminated layout marker")?;
        let name = &after[..name_end];
        let table = if name == "TYPES" {
            markdown_types()
        } else if name == "WORKER_TYPES" {
            markdown_worker_types()
        } else {
            let layout = all
                .iter()
                .find(|l| l.name == name)
                .ok_or_else(|| format!("docs name an unknown layout {name}"))?;
            markdown(layout)
        };
        let body = &after[name_end + 4..];
        let end = body
            .find(CLOSE)
            .ok_or_else(|| format!("layout {name} has no {CLOSE}"))?;
        out.push_str(&rest[..start]);
        let _ = write!(out, "{OPEN}{name} -->\n{table}{CLOSE}");
        rest = &body[end + CLOSE.len()..];
        seen.push(name.to_string());
    }
    out.push_str(rest);
    for name in all.iter().map(|l| l.name).chain(["TYPES", "WORKER_TYPES"]) {
        if !seen.iter().any(|s| s == name) {
            return Err(format!("docs have no block `{OPEN}{name} -->`"));
        }
    }
    Ok(out)
}
