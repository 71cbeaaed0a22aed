//! A nesting-depth check run before the XML parser: roxmltree (0.20) parses nested elements
//! recursively, so a small file of deeply nested tags would overflow the stack and abort.

use std::path::Path;

use crate::load::{LoadError, Location};

/// Fails when `text` opens more than `limit` elements inside each other.
///
/// A deliberately simple scan: comments, CDATA sections, processing instructions and
/// declarations are skipped, quoted attribute values may contain `>`, end tags close one
/// level and `/>` none. On malformed text it may count differently from the parser, which
/// then refuses the text itself; it never counts fewer levels than the parser recurses.
pub(super) fn check_nesting(path: &Path, text: &str, limit: usize) -> Result<(), LoadError> {
    let b = text.as_bytes();
    let (mut i, mut depth, mut line) = (0usize, 0usize, 1usize);
    // Advances past the next occurrence of `end`, counting lines; to the end if missing.
    let skip_past = |i: &mut usize, line: &mut usize, end: &[u8]| {
        while *i < b.len() && !b[*i..].starts_with(end) {
            *line += (b[*i] == b'\n') as usize;
            *i += 1;
        }
        *i = (*i + end.len()).min(b.len());
    };
    while i < b.len() {
        match b[i] {
            b'\n' => {
                line += 1;
                i += 1;
            }
            b'<' => {
                let rest = &b[i..];
                if rest.starts_with(b"<!--") {
                    skip_past(&mut i, &mut line, b"-->");
                } else if rest.starts_with(b"<![CDATA[") {
                    skip_past(&mut i, &mut line, b"]]>");
                } else if rest.starts_with(b"<?") {
                    skip_past(&mut i, &mut line, b"?>");
                } else if rest.starts_with(b"<!") || rest.starts_with(b"</") {
                    depth = depth.saturating_sub(rest.starts_with(b"</") as usize);
                    skip_past(&mut i, &mut line, b">");
                } else {
                    let start_line = line;
                    let self_closing = skip_tag(b, &mut i, &mut line);
                    if !self_closing {
                        depth += 1;
                        if depth > limit {
                            return Err(LoadError::invalid(
                                Location::line(path, start_line),
                                format!("elements are nested more than {limit} deep"),
                            ));
                        }
                    }
                }
            }
            _ => i += 1,
        }
    }
    Ok(())
}

/// Moves `i` past the start tag at `b[i]` (quoted values may hold `>`); true for `<.../>`.
fn skip_tag(b: &[u8], i: &mut usize, line: &mut usize) -> bool {
    let mut quote = None;
    let mut prev = 0u8;
    *i += 1;
    while *i < b.len() {
        let c = b[*i];
        *line += (c == b'\n') as usize;
        *i += 1;
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None if c == b'"' || c == b'\'' => quote = Some(c),
            None if c == b'>' => return prev == b'/',
            None => {}
        }
        prev = c;
    }
    false
}

#[cfg(test)]
mod tests {
    use super::check_nesting;
    use std::path::Path;

    fn depth_ok(text: &str, limit: usize) -> bool {
        check_nesting(Path::new("t.xml"), text, limit).is_ok()
    }

    #[test]
    fn counts_open_elements_only() {
        let doc = "<?xml version=\"1.0\"?>\n<!-- <a><a><a> -->\n<scene a=\"x>y\">\n\
                   <b/><c><![CDATA[<d><d><d>]]></c><e x='/>'><f/></e></scene>";
        // scene > e is the deepest: two levels.
        assert!(depth_ok(doc, 2));
        assert!(!depth_ok(doc, 1));
    }

    #[test]
    fn names_the_line_of_the_first_element_too_deep() {
        let e = check_nesting(Path::new("t.xml"), "<a>\n<b>\n<c>\n", 2).unwrap_err();
        assert!(e.to_string().starts_with("t.xml:3:"), "{e}");
    }
}
