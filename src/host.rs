//! The machine a render runs on: how much memory this process may still
//! allocate, from Linux's `/proc/meminfo` and the memory cgroups (v1 and v2)
//! it belongs to. Image reading caps what one texture may take by it; the
//! memory preflight compares its estimate with it.

use std::path::Path;

/// Bytes this process can still allocate before the system or its control
/// group runs out: the smaller of `/proc/meminfo`'s `MemAvailable` and the
/// cgroup (v2 `memory.max`, v1 `memory.limit_in_bytes`) limit minus its
/// working set, over the cgroup and its ancestors. `None` when neither can
/// be read (not Linux).
pub fn available_bytes() -> Option<u64> {
    let system = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| meminfo_available(&t));
    let cgroup = std::fs::read_to_string("/proc/self/cgroup")
        .ok()
        .and_then(|t| cgroup_headroom(&t, Path::new("/sys/fs/cgroup")));
    match (system, cgroup) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// `MemAvailable` of a `/proc/meminfo` text, bytes.
fn meminfo_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Limits at or above this are "no limit" (cgroup v1 writes 2^63 - 4096).
const UNLIMITED: u64 = 1 << 60;

/// The smallest headroom (limit minus usage, less reclaimable inactive file
/// cache) over the memory cgroups named in a `/proc/self/cgroup` text and
/// their ancestors, under the cgroup mount `root`; `None` when no limit is set.
fn cgroup_headroom(self_cgroup: &str, root: &Path) -> Option<u64> {
    let mut best: Option<u64> = None;
    for line in self_cgroup.lines() {
        let mut parts = line.splitn(3, ':');
        let (Some(_), Some(controllers), Some(path)) = (parts.next(), parts.next(), parts.next())
        else {
            continue;
        };
        // (mount folders, limit file, usage file, inactive-file key in memory.stat)
        let layouts: &[(&[&str], &str, &str, &str)] = if controllers.is_empty() {
            &[(
                &["", "unified"],
                "memory.max",
                "memory.current",
                "inactive_file",
            )]
        } else if controllers.split(',').any(|c| c == "memory") {
            &[(
                &["memory"],
                "memory.limit_in_bytes",
                "memory.usage_in_bytes",
                "total_inactive_file",
            )]
        } else {
            continue;
        };
        for &(mounts, limit_file, usage_file, inactive_key) in layouts {
            for mount in mounts {
                let base = root.join(mount);
                let mut dir = Some(Path::new(path.trim_start_matches('/')));
                while let Some(rel) = dir {
                    let at = base.join(rel);
                    let read = |f: &str| std::fs::read_to_string(at.join(f)).ok();
                    if let (Some(limit), Some(usage)) = (read(limit_file), read(usage_file)) {
                        let stat = read("memory.stat").unwrap_or_default();
                        if let Some(h) = headroom(&limit, &usage, &stat, inactive_key) {
                            best = Some(best.map_or(h, |b| b.min(h)));
                        }
                    }
                    dir = rel.parent();
                }
            }
        }
    }
    best
}

/// One cgroup's headroom from its limit, usage and `memory.stat` texts;
/// `None` for "max" or an effectively unlimited limit.
fn headroom(limit: &str, usage: &str, stat: &str, inactive_key: &str) -> Option<u64> {
    let limit: u64 = limit.trim().parse().ok().filter(|&l| l < UNLIMITED)?;
    let usage: u64 = usage.trim().parse().ok()?;
    let inactive: u64 = stat
        .lines()
        .find_map(|l| {
            l.strip_prefix(inactive_key)?
                .strip_prefix(' ')?
                .trim()
                .parse()
                .ok()
        })
        .unwrap_or(0);
    Some(limit.saturating_sub(usage.saturating_sub(inactive)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meminfo_and_cgroup_texts_give_the_headroom() {
        let meminfo = "MemTotal:  100 kB\nMemFree: 10 kB\nMemAvailable:   2048 kB\n";
        assert_eq!(meminfo_available(meminfo), Some(2 << 20));
        assert_eq!(meminfo_available("MemTotal: 1 kB\n"), None);
        assert_eq!(headroom("max\n", "5", "", "inactive_file"), None);
        assert_eq!(
            headroom("9223372036854771712", "5", "", "total_inactive_file"),
            None
        );
        let stat = "active_file 7\ninactive_file 300\n";
        assert_eq!(headroom("1000", "500", stat, "inactive_file"), Some(800));
        assert_eq!(headroom("1000", "1500", "", "inactive_file"), Some(0));

        // A v2 hierarchy whose parent is tighter than the leaf.
        let root = std::env::temp_dir().join(format!("cirrus-cgroup-{}", std::process::id()));
        let leaf = root.join("app/job");
        std::fs::create_dir_all(&leaf).unwrap();
        for (dir, max, current) in [(&leaf, "max", "100"), (&root.join("app"), "5000", "1000")] {
            std::fs::write(dir.join("memory.max"), max).unwrap();
            std::fs::write(dir.join("memory.current"), current).unwrap();
        }
        assert_eq!(cgroup_headroom("0::/app/job\n", &root), Some(4000));
        assert_eq!(cgroup_headroom("4:cpu:/app/job\n", &root), None);
        std::fs::remove_dir_all(&root).unwrap();
    }
}
