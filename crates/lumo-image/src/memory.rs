//! How much memory this process may still allocate: the least of what the machine has free
//! (MemAvailable), what its cgroup allows (v2 `memory.max`, v1 `memory.limit_in_bytes`, less
//! what the group uses) and what its address-space limit (RLIMIT_AS, as `ulimit -v` sets it)
//! leaves. MemAvailable alone let `lumo render --size 8192x8192` abort under a 2 GiB limit.
//!
//! `LUMO_MEMORY_LIMIT` (bytes, or with a K, M or G suffix: powers of 1024) replaces all of
//! these (tests use it to stand in for a small machine).

use std::path::{Path, PathBuf};

/// The environment variable that replaces the measured available memory.
pub const MEMORY_LIMIT_VAR: &str = "LUMO_MEMORY_LIMIT";

/// Bytes this process may still allocate, or `None` where nothing is known (then nothing is
/// refused). A malformed `LUMO_MEMORY_LIMIT` is ignored with a warning on stderr.
pub fn memory_available() -> Option<u64> {
    if let Ok(v) = std::env::var(MEMORY_LIMIT_VAR) {
        match parse_size(&v) {
            Some(n) => return Some(n),
            None => {
                // The warning is all that can be done; a closed stderr loses nothing else.
                use std::io::Write;
                let _ = writeln!(
                    std::io::stderr(),
                    "warning: {MEMORY_LIMIT_VAR}={v:?} is not a size like 512M; ignored"
                );
            }
        }
    }
    [
        mem_available(),
        cgroup_available(),
        address_space_available(),
    ]
    .into_iter()
    .flatten()
    .min()
}

/// `512M`, `2G`, `1048576`: a size in bytes with an optional K, M or G suffix (powers of 1024).
pub fn parse_size(v: &str) -> Option<u64> {
    let v = v.trim();
    let (digits, shift) = match v.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => {
            let shift = match c.to_ascii_uppercase() {
                'K' => 10,
                'M' => 20,
                'G' => 30,
                'B' => 0,
                _ => return None,
            };
            (&v[..i], shift)
        }
        _ => (v, 0),
    };
    digits
        .trim()
        .parse::<u64>()
        .ok()
        .map(|n| n.saturating_mul(1 << shift))
}

/// MemAvailable from /proc/meminfo.
fn mem_available() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    meminfo_field(&info, "MemAvailable:")
}

/// A `NAME: N kB` field of /proc/meminfo or /proc/self/status, in bytes.
fn meminfo_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kib: u64 = line[name.len()..].split_whitespace().next()?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// What the tightest memory cgroup around this process leaves: its limit less its usage, for
/// the process's own group and every group above it (a parent's limit binds its children).
fn cgroup_available() -> Option<u64> {
    let own = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    cgroup_available_in(Path::new("/sys/fs/cgroup"), &own)
}

/// [`cgroup_available`] with the cgroup file system at `root` and `/proc/self/cgroup`'s text.
pub fn cgroup_available_in(root: &Path, proc_self_cgroup: &str) -> Option<u64> {
    let mut best: Option<u64> = None;
    let mut consider = |limit: Option<u64>, usage: Option<u64>| {
        if let Some(limit) = limit {
            let free = limit.saturating_sub(usage.unwrap_or(0));
            best = Some(best.map_or(free, |b| b.min(free)));
        }
    };
    for line in proc_self_cgroup.lines() {
        // "hierarchy-ID:controllers:path"; v2 is "0::path", v1's memory line "N:memory:path".
        let mut parts = line.splitn(3, ':');
        let (Some(_), Some(controllers), Some(path)) = (parts.next(), parts.next(), parts.next())
        else {
            continue;
        };
        let (base, limit_file, usage_file) = if controllers.is_empty() {
            (root.to_path_buf(), "memory.max", "memory.current")
        } else if controllers.split(',').any(|c| c == "memory") {
            (
                root.join("memory"),
                "memory.limit_in_bytes",
                "memory.usage_in_bytes",
            )
        } else {
            continue;
        };
        // From the process's group up to the root (inside a container the path may not
        // exist under the mount, which then is the container's own group: the root is read).
        for dir in ancestors(&base, path) {
            consider(
                read_number(&dir.join(limit_file)),
                read_number(&dir.join(usage_file)),
            );
        }
    }
    best
}

/// `base/path` and each of its parents down to `base` itself.
fn ancestors(base: &Path, path: &str) -> Vec<PathBuf> {
    let mut dirs = vec![base.to_path_buf()];
    let mut dir = base.to_path_buf();
    for part in path.split('/').filter(|p| !p.is_empty() && *p != "..") {
        dir.push(part);
        dirs.push(dir.clone());
    }
    dirs
}

/// A file holding one number; `None` for "max", a missing file or v1's "no limit" (a value
/// near 2^63).
fn read_number(path: &Path) -> Option<u64> {
    let text = std::fs::read_to_string(path).ok()?;
    let n: u64 = text.trim().parse().ok()?;
    (n < 1 << 62).then_some(n)
}

/// What RLIMIT_AS leaves: the soft "Max address space" of /proc/self/limits less the
/// process's current address space (VmSize of /proc/self/status).
fn address_space_available() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let limit = address_space_limit(&limits)?;
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let used = meminfo_field(&status, "VmSize:").unwrap_or(0);
    Some(limit.saturating_sub(used))
}

/// The soft address-space limit in /proc/self/limits's text (`None`: unlimited).
pub fn address_space_limit(limits: &str) -> Option<u64> {
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..]
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// `n` bytes in binary units for messages ("79.00 GiB"; two decimals, so that a need just
/// over what is available does not print as the same number).
pub fn format_bytes(n: u64) -> String {
    let n = n as f64;
    if n >= (1u64 << 30) as f64 {
        format!("{:.2} GiB", n / (1u64 << 30) as f64)
    } else if n >= (1u64 << 20) as f64 {
        format!("{:.1} MiB", n / (1u64 << 20) as f64)
    } else {
        format!("{:.0} KiB", n / 1024.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes() {
        assert_eq!(parse_size("512M"), Some(512 << 20));
        assert_eq!(parse_size(" 2g "), Some(2 << 30));
        assert_eq!(parse_size("100000"), Some(100000));
        assert_eq!(parse_size("12X"), None);
        assert_eq!(parse_size("lots"), None);
    }

    #[test]
    fn rlimit_as_is_read_from_proc_self_limits() {
        let text = "Limit                     Soft Limit           Hard Limit           Units     \n\
                    Max stack size            8388608              unlimited            bytes     \n\
                    Max address space         2147483648           unlimited            bytes     \n";
        assert_eq!(address_space_limit(text), Some(2 << 30));
        let unlimited = "Max address space         unlimited            unlimited            bytes";
        assert_eq!(address_space_limit(unlimited), None);
    }

    #[test]
    fn cgroup_limits_of_v1_and_v2_and_their_parents_bind() {
        let root = std::env::temp_dir().join(format!("lumo-cgroup-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let v2 = root.join("user.slice/job");
        std::fs::create_dir_all(&v2).unwrap();
        std::fs::write(root.join("user.slice/memory.max"), "3221225472\n").unwrap();
        std::fs::write(root.join("user.slice/memory.current"), "1073741824\n").unwrap();
        std::fs::write(v2.join("memory.max"), "max\n").unwrap();
        // The parent's 3 GiB limit less its 1 GiB in use binds the unlimited child.
        assert_eq!(
            cgroup_available_in(&root, "0::/user.slice/job\n"),
            Some(2 << 30)
        );
        let v1 = root.join("memory/docker/abc");
        std::fs::create_dir_all(&v1).unwrap();
        std::fs::write(v1.join("memory.limit_in_bytes"), "2147483648").unwrap();
        std::fs::write(v1.join("memory.usage_in_bytes"), "536870912").unwrap();
        std::fs::write(
            root.join("memory/memory.limit_in_bytes"),
            "9223372036854771712",
        )
        .unwrap();
        assert_eq!(
            cgroup_available_in(&root, "5:memory:/docker/abc\n3:cpu,cpuacct:/docker/abc\n"),
            Some(3 << 29)
        );
        assert_eq!(cgroup_available_in(&root, "4:cpu:/x\n"), None);
        std::fs::remove_dir_all(&root).ok();
    }
}
