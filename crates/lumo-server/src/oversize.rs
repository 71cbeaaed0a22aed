//! The answer to a request that outgrows [`crate::Limits::max_request_bytes`]: 414, 431 or 413
//! by how far the request got, written below HTTP by [`crate::conn::GuardedStream`] (hyper
//! never sees the request, so it cannot answer it; it used to drop the connection with an
//! empty reply).

/// How far the bytes of a request have got: the end of its request line, and of its head.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct HeadScan {
    line_done: bool,
    head_done: bool,
    /// The last four bytes, newest lowest (to find the blank line across reads).
    last: u32,
}

impl HeadScan {
    /// Takes the next bytes of the request.
    pub fn feed(&mut self, bytes: &[u8]) {
        if self.head_done {
            return;
        }
        for &b in bytes {
            self.last = (self.last << 8) | u32::from(b);
            if b == b'\n' {
                // "\r\n\r\n", or "\n\n" from a client that sends bare line feeds.
                if self.last == u32::from_be_bytes(*b"\r\n\r\n") || self.last & 0xffff == 0x0a0a {
                    self.head_done = true;
                    return;
                }
                self.line_done = true;
            }
        }
    }

    /// The status and the reason of refusing a request that has got this far, with `cap` the
    /// size cap in bytes.
    pub fn refusal(&self, cap: usize) -> (u16, &'static str, String) {
        if !self.line_done {
            (
                414,
                "URI Too Long",
                format!("request line longer than {cap} bytes"),
            )
        } else if !self.head_done {
            (
                431,
                "Request Header Fields Too Large",
                format!("request headers larger than {cap} bytes"),
            )
        } else {
            (
                413,
                "Content Too Large",
                format!("request larger than {cap} bytes (this server takes no request bodies)"),
            )
        }
    }
}

/// The complete HTTP/1.1 response that refuses a request (`Connection: close`: the rest of
/// the request is read and dropped, never parsed).
pub(crate) fn refusal_response(scan: &HeadScan, cap: usize) -> Vec<u8> {
    let (status, reason, text) = scan.refusal(cap);
    let body = format!("{status} {reason}: {text}\n");
    format!(
        "HTTP/1.1 {status} {reason}\r\ncontent-type: text/plain; charset=utf-8\r\n\
         content-length: {}\r\nconnection: close\r\n\r\n{body}",
        body.len()
    )
    .into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn status(chunks: &[&[u8]]) -> u16 {
        let mut scan = HeadScan::default();
        for c in chunks {
            scan.feed(c);
        }
        scan.refusal(10).0
    }

    #[test]
    fn the_status_follows_how_far_the_request_got() {
        assert_eq!(status(&[b"GET /aaaaaaaa"]), 414);
        assert_eq!(status(&[b"GET / HTTP/1.1\r\nHost: x\r\nX-Big: aaaa"]), 431);
        // The blank line split across reads, and bare line feeds.
        assert_eq!(
            status(&[b"GET / HTTP/1.1\r\nHost: x\r", b"\n\r", b"\nbody"]),
            413
        );
        assert_eq!(status(&[b"GET / HTTP/1.1\nHost: x\n\nbody"]), 413);
        // A line ending alone is not a blank line.
        assert_eq!(status(&[b"GET / HTTP/1.1\r\n", b"Host: x\r\n"]), 431);
    }

    #[test]
    fn the_response_is_complete_http() {
        let mut scan = HeadScan::default();
        scan.feed(b"GET /aaaa");
        let r = String::from_utf8(refusal_response(&scan, 65536)).expect("text");
        assert!(r.starts_with("HTTP/1.1 414 URI Too Long\r\n"), "{r}");
        let (head, body) = r.split_once("\r\n\r\n").expect("head and body");
        assert!(
            head.contains(&format!("content-length: {}", body.len())),
            "{r}"
        );
        assert!(body.contains("65536 bytes"), "{r}");
    }
}
