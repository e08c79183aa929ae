//! Campaigns larger than one machine (issue 29): `sweep --shard K/N` flies the K-th of N
//! disjoint, deterministic slices of a campaign's runs (levels x seeds) and writes
//! `shard.json`; `sweep merge DIR...` checks that the shards are one campaign's and cover every
//! run exactly once, and gives back the rows in the campaign's (level, seed) order, so
//! `sweep.csv`, `sweep.json` and the plots are those of an unsharded run (byte for byte: the
//! runs are deterministic and the statistics see the same rows in the same order).
//!
//! Run `i` of the campaign's work list ([`super::work`]) belongs to shard `i mod N + 1`:
//! interleaved, so every shard gets a share of every level (each level's runs cost alike).

use super::{Campaign, Row};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Shard `index` of `count` (1-based: `1/4` .. `4/4`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShardSpec {
    /// Which shard, 1..=count.
    pub index: usize,
    /// How many shards.
    pub count: usize,
}

impl ShardSpec {
    /// Whether run number `run` (0-based, in the campaign's order) is this shard's.
    pub fn owns(self, run: usize) -> bool {
        run % self.count + 1 == self.index
    }
}

impl std::str::FromStr for ShardSpec {
    type Err = String;

    /// `K/N` with `1 <= K <= N`.
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("`{s}`: give K/N with 1 <= K <= N (e.g. 3/8)");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count) = (k.trim().parse::<usize>().map_err(|_| bad())?, n.trim().parse::<usize>().map_err(|_| bad())?);
        if index == 0 || index > count {
            return Err(bad());
        }
        Ok(Self { index, count })
    }
}

/// One run of a shard: its number in the campaign and its row.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ShardRow {
    /// Run number in the campaign's (level, seed) order.
    pub run: usize,
    /// The row.
    pub row: Row,
}

/// `shard.json`: what one shard flew, and of which campaign.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ShardFile {
    /// The campaign's (merged scenario's) name.
    pub campaign: String,
    /// The dotted key its levels set.
    pub level_key: Option<String>,
    /// The level values, in order (`[null]` without levels).
    pub levels: Vec<Option<f64>>,
    /// First seed.
    pub first_seed: u64,
    /// Runs per level.
    pub runs: usize,
    /// Which shard.
    pub shard: ShardSpec,
    /// Its runs.
    pub rows: Vec<ShardRow>,
}

impl ShardFile {
    /// The shard file of `rows` (run number, row), flown from `c` with `runs` and `first_seed`.
    pub fn new(c: &Campaign, runs: usize, first_seed: u64, shard: ShardSpec, rows: Vec<(usize, Row)>) -> Self {
        Self {
            campaign: c.name.clone(),
            level_key: c.level_key.clone(),
            levels: c.levels.iter().map(|(l, _)| *l).collect(),
            first_seed,
            runs,
            shard,
            rows: rows.into_iter().map(|(run, row)| ShardRow { run, row }).collect(),
        }
    }

    /// Reads `DIR/shard.json`.
    ///
    /// # Errors
    /// Unreadable or not a shard file (message names the file).
    pub fn read(dir: &Path) -> Result<Self, String> {
        let path = dir.join("shard.json");
        let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e} (a directory written by `sweep --shard K/N`)", path.display()))?;
        serde_json::from_str(&text).map_err(|e| format!("{}:{}: {e}", path.display(), e.line()))
    }
}

/// The shards of one campaign combined: the campaign's identity and every row in its
/// (level, seed) order.
#[derive(Debug, Clone, PartialEq)]
pub struct Merged {
    /// Campaign name.
    pub campaign: String,
    /// Level key.
    pub level_key: Option<String>,
    /// Level values.
    pub levels: Vec<Option<f64>>,
    /// First seed.
    pub first_seed: u64,
    /// Every row, in the campaign's order.
    pub rows: Vec<Row>,
}

/// Combines shards (each with the name of where it came from, for errors).
///
/// # Errors
/// Shards of different campaigns, a shard missing or given twice, a run missing or twice.
pub fn merge(shards: &[(String, ShardFile)]) -> Result<Merged, String> {
    let Some((_, first)) = shards.first() else {
        return Err("no shards given".into());
    };
    let count = first.shard.count;
    let mut seen = vec![false; count];
    for (src, s) in shards {
        let same = s.campaign == first.campaign
            && s.level_key == first.level_key
            && s.levels.iter().map(|l| l.map(f64::to_bits)).eq(first.levels.iter().map(|l| l.map(f64::to_bits)))
            && s.first_seed == first.first_seed
            && s.runs == first.runs
            && s.shard.count == count;
        if !same {
            return Err(format!(
                "{src}: shard {}/{} of `{}` (levels {:?}, seed {}, {} runs) is not of the campaign of the first shard (`{}`, {:?}, seed {}, {} runs, {count} shards)",
                s.shard.index, s.shard.count, s.campaign, s.levels, s.first_seed, s.runs, first.campaign, first.levels, first.first_seed, first.runs
            ));
        }
        match seen.get_mut(s.shard.index.wrapping_sub(1)) {
            Some(slot) if !*slot => *slot = true,
            Some(_) => return Err(format!("{src}: shard {}/{count} given twice", s.shard.index)),
            None => return Err(format!("{src}: shard {}/{count} is out of range", s.shard.index)),
        }
    }
    if let Some(k) = seen.iter().position(|s| !s) {
        return Err(format!("shard {}/{count} is missing", k + 1));
    }
    let total = first.levels.len() * first.runs;
    let mut rows: Vec<Option<Row>> = vec![None; total];
    for (src, s) in shards {
        for r in &s.rows {
            if !s.shard.owns(r.run) {
                return Err(format!("{src}: run {} is not shard {}/{count}'s", r.run, s.shard.index));
            }
            match rows.get_mut(r.run) {
                Some(slot @ None) => *slot = Some(r.row.clone()),
                Some(Some(_)) => return Err(format!("{src}: run {} given twice", r.run)),
                None => return Err(format!("{src}: run {} beyond the campaign's {total}", r.run)),
            }
        }
    }
    let missing: Vec<usize> = rows.iter().enumerate().filter(|(_, r)| r.is_none()).map(|(i, _)| i).collect();
    if !missing.is_empty() {
        return Err(format!("{} of {total} runs missing (first: run {}); was a shard cut short?", missing.len(), missing[0]));
    }
    Ok(Merged {
        campaign: first.campaign.clone(),
        level_key: first.level_key.clone(),
        levels: first.levels.clone(),
        first_seed: first.first_seed,
        rows: rows.into_iter().flatten().collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::super::{csv, fly, fly_shard, load, report, report_for};
    use super::*;

    fn campaign() -> Campaign {
        let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml");
        let dir = std::env::temp_dir().join(format!("vt-shard-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
        let file = dir.join("noisy.toml");
        let text = format!(
            "base = {:?}\nruns = 3\nseed = 40\n[disturbances]\nposition_noise_m = 0.05\ngust_std_mps = 1.0\n[mission]\ntime_limit_s = 6.0\n[levels]\nkey = \"disturbances.intensity\"\nvalues = [0.5, 2.0]\n",
            base.display().to_string()
        );
        std::fs::write(&file, text).unwrap_or_else(|e| panic!("{e}"));
        load(Some(&file)).unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn shards_merge_to_the_unsharded_campaign_byte_for_byte() {
        let c = campaign();
        let whole = fly(&c, c.runs, c.seed, 2, false).unwrap_or_else(|e| panic!("{e}"));
        let mut shards = Vec::new();
        // Out of order on purpose; each through its JSON file, as between machines.
        for k in [3, 1, 2, 4] {
            let spec = ShardSpec { index: k, count: 4 };
            let rows = fly_shard(&c, c.runs, c.seed, 1, false, Some(spec)).unwrap_or_else(|e| panic!("{e}"));
            let text = serde_json::to_string(&ShardFile::new(&c, c.runs, c.seed, spec, rows)).unwrap_or_default();
            shards.push((format!("shard{k}"), serde_json::from_str::<ShardFile>(&text).unwrap_or_else(|e| panic!("{e}"))));
        }
        let m = merge(&shards).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(csv(&m.rows), csv(&whole));
        let a = serde_json::to_string(&report(&c, c.seed, &whole)).unwrap_or_default();
        let b = serde_json::to_string(&report_for(&m.campaign, m.level_key.as_deref(), &m.levels, m.first_seed, &m.rows)).unwrap_or_default();
        assert_eq!(a, b);
        assert_eq!(m.rows.len(), 6);
        // Incomplete or mixed inputs are refused, naming the shard.
        let e = merge(&shards[..3]).expect_err("a shard missing");
        assert!(e.contains("shard 4/4 is missing"), "{e}");
        let mut twice = shards.clone();
        twice.push(shards[0].clone());
        assert!(merge(&twice).expect_err("twice").contains("given twice"));
        let mut other = shards.clone();
        other[1].1.first_seed += 1;
        assert!(merge(&other).expect_err("other campaign").starts_with("shard1: "));
        let mut cut = shards.clone();
        cut[0].1.rows.pop();
        assert!(merge(&cut).expect_err("cut short").contains("runs missing"));
    }

    #[test]
    fn shard_specs_parse_and_partition_the_runs() {
        assert_eq!("3/8".parse::<ShardSpec>(), Ok(ShardSpec { index: 3, count: 8 }));
        for bad in ["0/4", "5/4", "4", "a/b", "1/0"] {
            assert!(bad.parse::<ShardSpec>().is_err(), "{bad}");
        }
        let specs: Vec<ShardSpec> = (1..=5).map(|index| ShardSpec { index, count: 5 }).collect();
        for run in 0..100 {
            assert_eq!(specs.iter().filter(|s| s.owns(run)).count(), 1, "run {run}");
        }
    }
}
