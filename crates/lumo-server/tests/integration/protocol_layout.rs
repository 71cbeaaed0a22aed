//! The wire layout's other two copies are generated from the Rust field tables
//! (`lumo_server::protocol::generate`): `web/protocol_layout.js`, from which the viewer's
//! `web/protocol.js` takes every offset and code, and the message tables of docs/protocol.md.
//! This test fails when either committed file differs from what the tables say, so a change
//! to a message cannot leave the viewer or the docs behind.
//!
//! After an intended change: `LUMO_BLESS=1 cargo test --release -p lumo-server --test
//! integration protocol_layout` rewrites both (then run the node tests, which decode the
//! golden files with the new layout).

use std::path::PathBuf;

use lumo_server::protocol::generate;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Compares `path` with `want`, or writes it when blessing.
fn check(path: PathBuf, want: &str) {
    if std::env::var_os("LUMO_BLESS").is_some() {
        std::fs::write(&path, want).unwrap();
        return;
    }
    let have = std::fs::read_to_string(&path).unwrap_or_default();
    if have != want {
        let line = have
            .lines()
            .zip(want.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(have.lines().count().min(want.lines().count()));
        panic!(
            "{} differs from the Rust field tables from line {} on (LUMO_BLESS=1 rewrites it)",
            path.display(),
            line + 1
        );
    }
}

#[test]
fn web_protocol_layout_is_generated_from_the_tables() {
    check(
        root().join("web/protocol_layout.js"),
        &generate::javascript(),
    );
}

#[test]
fn docs_message_tables_are_generated_from_the_tables() {
    let path = root().join("docs/protocol.md");
    let doc = std::fs::read_to_string(&path).unwrap();
    let want = generate::update_markdown(&doc).unwrap_or_else(|e| panic!("docs/protocol.md: {e}"));
    check(path, &want);
}

/// The viewer serves what it imports: the generated module is one of the embedded assets.
#[test]
fn the_layout_module_is_served_to_the_viewer() {
    let a = lumo_server::assets::find("/protocol_layout.js").expect("embedded");
    assert!(
        a.body == generate::javascript(),
        "the embedded web/protocol_layout.js is stale (after blessing, the next build embeds it)"
    );
    let p = lumo_server::assets::find("/protocol.js").expect("embedded");
    assert!(p.body.contains("from './protocol_layout.js'"));
}
