//! Issue 29: campaigns larger than one machine. `host-sim sweep --shard K/N` on separate
//! "machines" (processes, directories) and `host-sim sweep merge` give the files of one
//! unsharded `sweep`, byte for byte; an incomplete set of shards is refused (exit 2).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use std::path::{Path, PathBuf};
use std::process::Command;

fn host_sim(args: &[&str]) -> (Option<i32>, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_host-sim")).args(args).output().unwrap();
    (o.status.code(), String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr))
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn three_shards_merge_to_the_unsharded_sweep_byte_for_byte() {
    let dir = std::env::temp_dir().join(format!("vt-sweep-shards-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml");
    let campaign = dir.join("windy.toml");
    std::fs::write(
        &campaign,
        format!(
            "base = {:?}\nruns = 3\nseed = 7\n[disturbances]\nwind_mean_mps = [1.0, 0.5, 0.0]\ngust_std_mps = 0.5\nposition_noise_m = 0.03\n[levels]\nkey = \"disturbances.intensity\"\nvalues = [1.0, 3.0]\n",
            base.display().to_string()
        ),
    )
    .unwrap();
    let whole = dir.join("whole");
    let (code, text) = host_sim(&["sweep", s(&campaign), "--out", s(&whole), "--jobs", "2"]);
    assert_eq!(code, Some(0), "{text}");
    let shards: Vec<PathBuf> = (1..=3).map(|k| dir.join(format!("shard{k}"))).collect();
    for (k, d) in shards.iter().enumerate() {
        let (code, text) = host_sim(&["sweep", s(&campaign), "--shard", &format!("{}/3", k + 1), "--out", s(d), "--jobs", "1"]);
        assert_eq!(code, Some(0), "{text}");
        assert!(text.contains(&format!("shard {}/3: 2 runs", k + 1)), "{text}");
    }
    let merged = dir.join("merged");
    // Any order of the directories.
    let (code, text) = host_sim(&["sweep", "merge", s(&shards[2]), s(&shards[0]), s(&shards[1]), "--out", s(&merged)]);
    assert_eq!(code, Some(0), "{text}");
    for f in ["sweep.csv", "sweep.json", "success_rate_vs_level.png"] {
        let a = std::fs::read(whole.join(f)).unwrap();
        let b = std::fs::read(merged.join(f)).unwrap();
        assert!(a == b, "{f} differs between the unsharded and the merged sweep");
    }
    assert_eq!(std::fs::read_to_string(merged.join("sweep.csv")).unwrap().lines().count(), 1 + 6);
    // A shard missing: bad input, named.
    let (code, text) = host_sim(&["sweep", "merge", s(&shards[0]), s(&shards[1]), "--out", s(&dir.join("partial"))]);
    assert_eq!(code, Some(2), "{text}");
    assert!(text.contains("shard 3/3 is missing"), "{text}");
    let (code, text) = host_sim(&["sweep", s(&campaign), "--shard", "4/3"]);
    assert_eq!(code, Some(2), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}
