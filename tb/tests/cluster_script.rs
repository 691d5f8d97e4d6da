//! `scripts/slurm-sweep.sh` against a stand-in `sbatch` that runs each job at once with an empty
//! environment, as Slurm does under `--export=NONE`: the jobs find the binary, the report folder
//! and the scene data from their command lines alone, paths with quotes and spaces included, and
//! the shards and collect write the report of one process.

mod common;
use common::TmpDir;

use std::io::Write;
use std::process::Command;

/// `sbatch` as far as the script uses it: `--array=0-K` runs the `--wrap` command once per task
/// with `SLURM_ARRAY_TASK_ID` set, anything else once; every job under `env -i` (the only
/// variables Slurm itself sets in a job), in the submitting folder; prints a job id.
const FAKE_SBATCH: &str = r#"#!/bin/sh
array=""; wrap=""
for a in "$@"; do
    case $a in
        --array=*) array=${a#--array=} ;;
        --wrap=*) wrap=${a#--wrap=} ;;
        --export=*) echo "the script should not need --export" >&2; exit 1 ;;
    esac
done
if [ -n "$array" ]; then
    i=0
    while [ $i -le "${array#0-}" ]; do
        env -i SLURM_ARRAY_TASK_ID=$i /bin/sh -c "$wrap" >&2 || exit 1
        i=$((i + 1))
    done
else
    env -i /bin/sh -c "$wrap" >&2 || exit 1
fi
echo 4242
"#;

#[test]
fn the_slurm_script_runs_under_an_empty_environment_with_quoted_paths() {
    let tmp = TmpDir::new("cluster", "slurm");
    // The binary alone (no shared/scenes above it), as the jobs would find it on a cluster.
    let bin = tmp.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let sms = bin.join("sms");
    std::fs::copy(env!("CARGO_BIN_EXE_sms"), &sms).unwrap();
    let sbatch = bin.join("sbatch");
    std::fs::write(&sbatch, FAKE_SBATCH).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&sbatch, std::fs::Permissions::from_mode(0o755)).unwrap();
    // Scene data named only by SMS_SCENES_DIR in the submitting shell: a cube as the bunny.
    let data = tmp.join("data 'x'");
    std::fs::create_dir_all(&data).unwrap();
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n").unwrap();
    std::fs::write(data.join("stanford-bunny-69k.obj.gz"), gz.finish().unwrap()).unwrap();
    let work = tmp.join("work");
    std::fs::create_dir_all(&work).unwrap();

    let tiny = [
        "--scenes",
        "bunny69k,wknd",
        "--res",
        "8x8",
        "--spp",
        "1",
        "--bounces",
        "1",
        "--configs",
        "SMS",
        "--rb-sizes",
        "8",
        "--l1d-sizes",
        "64",
        "--jobs",
        "1",
        "-q",
    ];
    let out = tmp.join("it's a \"report\" $HOME");
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/../scripts/slurm-sweep.sh");
    let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap_or_default());
    let o = Command::new("sh")
        .arg(script)
        .args(["2", out.to_str().unwrap()])
        .args(tiny)
        .current_dir(&work)
        .env("PATH", path)
        .env("SMS", &sms)
        .env("SMS_SCENES_DIR", &data)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("submitted shards 4242 (0..1) and collect 4242"));
    assert!(out.join("summary.md").exists(), "the collect job wrote the report: {err}");

    // The same sweep in one process gives the same report.
    let whole = tmp.join("whole");
    let o = Command::new(&sms)
        .arg("sweep")
        .args(tiny)
        .args(["--no-cache", "--out", whole.to_str().unwrap()])
        .env("SMS_SCENES_DIR", &data)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    common::assert_same_reports(&whole, &out, "two Slurm shards and a collect");
}
