//! The process's peak memory and CPU time, for reports (`sms sweep`, `sms ablate`, the benches;
//! callable from anywhere).

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

/// CPU time this process has used so far (user + system, every thread, finished ones included),
/// in seconds: fields 14 and 15 of `/proc/self/stat`, in the kernel's fixed `USER_HZ` of 100 ticks
/// a second (10 ms resolution). `None` where that file does not exist.
pub fn process_cpu_seconds() -> Option<f64> {
    parse_cpu_ticks(&std::fs::read_to_string("/proc/self/stat").ok()?).map(|t| t as f64 / 100.0)
}

/// utime + stime of a `/proc/<pid>/stat` line (the fields after the parenthesised name, which may
/// hold spaces).
fn parse_cpu_ticks(stat: &str) -> Option<u64> {
    let rest = &stat[stat.rfind(')')? + 1..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    // After the name: state is field 3, so utime (14) and stime (15) are at 11 and 12 here.
    Some(f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?)
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
    fn cpu_ticks_are_utime_plus_stime_after_the_name() {
        let stat = "4242 (sms run) R 1 2 3 4 5 6 7 8 9 10 250 31 0 0 20 0 3 0 100 200 300";
        assert_eq!(parse_cpu_ticks(stat), Some(281));
        assert_eq!(parse_cpu_ticks("4242 (x) R 1"), None);
        if cfg!(target_os = "linux") {
            // Spin until the count moves 50 ms on (a count stuck at its first value, or a parse of
            // the wrong fields, never gets there), giving up after 10 s of wall time.
            let before = process_cpu_seconds().expect("/proc/self/stat on Linux");
            let t = std::time::Instant::now();
            let mut x = 0u64;
            while process_cpu_seconds().unwrap() < before + 0.05 && t.elapsed().as_secs() < 10 {
                x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
            }
            assert!(process_cpu_seconds().unwrap() >= before + 0.05, "spinning is counted");
        }
    }

    #[test]
    fn sizes_read_in_mib_or_gib() {
        assert_eq!(describe(None), "unknown");
        assert_eq!(describe(Some(300 << 20)), "300 MiB");
        assert_eq!(describe(Some(3 << 30)), "3.00 GiB");
    }
}
