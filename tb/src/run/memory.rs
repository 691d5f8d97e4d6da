//! The process's peak memory, for reports (`sms sweep`, `sms ablate`; callable from anywhere).

/// Peak resident set size of this process so far, in bytes: Linux's `VmHWM` ("high water mark")
/// from `/proc/self/status`. `None` where that file does not exist or cannot be read.
pub fn peak_rss_bytes() -> Option<u64> {
    parse_vm_hwm(&std::fs::read_to_string("/proc/self/status").ok()?)
}

/// The `VmHWM:  1234 kB` line of a `/proc/<pid>/status` text, in bytes.
fn parse_vm_hwm(status: &str) -> Option<u64> {
    let line = status.lines().find_map(|l| l.strip_prefix("VmHWM:"))?;
    let kb: u64 = line.trim().strip_suffix("kB")?.trim().parse().ok()?;
    Some(kb * 1024)
}

/// `bytes` for people: MiB below one GiB, GiB with two decimals above; "unknown" for `None`.
pub fn describe(bytes: Option<u64>) -> String {
    const MIB: f64 = 1024.0 * 1024.0;
    match bytes {
        None => "unknown".into(),
        Some(b) if (b as f64) < 1024.0 * MIB => format!("{:.0} MiB", b as f64 / MIB),
        Some(b) => format!("{:.2} GiB", b as f64 / (1024.0 * MIB)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_high_water_mark_line() {
        let status = "Name:\tsms\nVmPeak:\t  999 kB\nVmHWM:\t    2048 kB\nVmRSS:\t  1024 kB\n";
        assert_eq!(parse_vm_hwm(status), Some(2048 * 1024));
        assert_eq!(parse_vm_hwm("VmRSS:\t1024 kB\n"), None);
        assert_eq!(parse_vm_hwm("VmHWM:\tmany kB\n"), None);
    }

    #[test]
    fn this_process_has_a_peak_on_linux() {
        if cfg!(target_os = "linux") {
            let peak = peak_rss_bytes().expect("VmHWM on Linux");
            // Holding 64 MiB raises the high water mark at least that far.
            let block = vec![1u8; 64 << 20];
            assert!(peak_rss_bytes().unwrap() >= (64 << 20) && block.iter().all(|&b| b == 1));
            assert!(peak_rss_bytes().unwrap() >= peak);
        }
    }

    #[test]
    fn sizes_read_in_mib_or_gib() {
        assert_eq!(describe(None), "unknown");
        assert_eq!(describe(Some(300 << 20)), "300 MiB");
        assert_eq!(describe(Some(3 << 30)), "3.00 GiB");
    }
}
