//! Refusing up front what cannot fit: a render or an image whose buffers would exceed the memory
//! the machine has free fails with one line before anything is allocated, instead of being killed
//! by the kernel hours later (or taking the machine down with it).

use crate::error::{Error, Result};

/// Environment variable with a cap in bytes that applies on top of the machine's free memory
/// (to keep a tool from claiming a shared machine; also how the tests exercise the refusal).
pub const LIMIT_VAR: &str = "MIXMC_MAX_MEMORY";

/// The memory a new allocation may use: `MemAvailable` of `/proc/meminfo` (free memory plus
/// caches the kernel can drop), lowered by `MIXMC_MAX_MEMORY`. `None` where neither is known.
pub fn budget() -> Result<Option<u64>> {
    let cap = match std::env::var(LIMIT_VAR) {
        Ok(v) => Some(
            v.trim()
                .parse::<u64>()
                .map_err(|_| Error::new(format!("{LIMIT_VAR}={v}: expected a number of bytes")))?,
        ),
        Err(_) => None,
    };
    let available = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| mem_available(&t));
    Ok(match (cap, available) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    })
}

/// `MemAvailable` in bytes from the text of `/proc/meminfo`.
fn mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kb.checked_mul(1024)
}

/// Fail with "`what` needs about N GB but only M GB are available" when `bytes` exceed the budget.
pub fn check(what: &str, bytes: u64) -> Result<()> {
    match budget()? {
        Some(limit) if bytes > limit => Err(Error::new(format!(
            "{what} needs about {} but only {} of memory are available",
            human(bytes),
            human(limit)
        ))),
        _ => Ok(()),
    }
}

/// Bytes in the largest unit that keeps the number ≥ 1 (1 decimal).
fn human(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KB", "MB", "GB", "TB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1000.0 && u + 1 < UNITS.len() {
        v /= 1000.0;
        u += 1;
    }
    format!("{v:.1} {}", UNITS[u])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_mem_available_and_formats_sizes() {
        let text = "MemTotal:       32000000 kB\nMemFree:  100 kB\nMemAvailable:   23419700 kB\n";
        assert_eq!(mem_available(text), Some(23_419_700 * 1024));
        assert_eq!(mem_available("MemTotal: 5 kB\n"), None);
        assert_eq!(human(999), "999.0 B");
        assert_eq!(human(6_600_000_000_000), "6.6 TB");
    }

    #[test]
    fn refuses_beyond_the_machine() {
        // No machine has an exabyte free.
        let e = check("a test", 1 << 60).unwrap_err();
        assert!(
            e.message.starts_with("a test needs about 1152921.5 TB"),
            "{e}"
        );
        assert!(check("a test", 1).is_ok());
    }
}
