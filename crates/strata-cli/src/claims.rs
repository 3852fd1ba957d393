//! The seeds' quantitative claims next to strata's measured figures: `strata report` writes one
//! table (the `claims` block of bench/REPORT.md) with, per claim, the paper's figure, ours on
//! each device that has the results it needs, and ours / paper.
//!
//! A claim is a ratio the paper states (a speedup, a memory saving) and a function that computes
//! the same ratio from one device's results files. A claim whose results are missing on a device
//! shows an empty cell; nothing is estimated.

use std::collections::BTreeMap;

use serde_json::Value;

/// One device's results: experiment name → its results file.
pub type DeviceFiles = BTreeMap<String, Value>;

pub struct Claim {
    pub seed: &'static str,
    pub claim: &'static str,
    /// The paper's figure, as the ratio `ours` computes.
    pub paper: f64,
    /// Our figure from one device's results.
    pub ours: fn(&DeviceFiles) -> Option<f64>,
}

fn rows<'a>(files: &'a DeviceFiles, experiment: &str) -> Vec<&'a Value> {
    let Some(file) = files.get(experiment) else {
        return Vec::new();
    };
    ["rows", "results"]
        .iter()
        .find_map(|t| file.get(*t)?.as_array())
        .map(|rows| rows.iter().collect())
        .unwrap_or_default()
}

fn str_of<'a>(row: &'a Value, field: &str) -> &'a str {
    row.get(field).and_then(Value::as_str).unwrap_or("")
}

fn num(row: &Value, field: &str) -> Option<f64> {
    row.get(field)?.as_f64().filter(|v| v.is_finite())
}

/// The median GPU ms of the rows of `experiment` that `pick` selects (rows without a time are
/// left out); `None` when none has one.
fn ms_of(files: &DeviceFiles, experiment: &str, pick: impl Fn(&Value) -> bool) -> Option<f64> {
    let times: Vec<f64> = rows(files, experiment)
        .into_iter()
        .filter(|r| pick(r))
        .filter_map(|r| num(r, "median_gpu_ms").or_else(|| num(r, "gpu_ms")))
        .collect();
    (!times.is_empty()).then(|| strata::metrics::median(times))
}

fn ratio(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    let (a, b) = (a?, b?);
    (b > 0.0).then_some(a / b)
}

/// `realtime`'s time of `method` on the dragon.
fn dragon(files: &DeviceFiles, method: &str) -> Option<f64> {
    ms_of(files, "realtime", |r| {
        str_of(r, "scene") == "builtin:dragon" && str_of(r, "method") == method
    })
}

/// `kbuffer-k`'s time of `method` at k = 64.
fn at_k64(files: &DeviceFiles, method: &str) -> Option<f64> {
    ms_of(files, "kbuffer-k", |r| {
        str_of(r, "method") == method && num(r, "k") == Some(64.0)
    })
}

/// `online-culling`'s time of the paper's method (semi-heap with temporal culling) on the balls
/// in `order`.
fn online(files: &DeviceFiles, order: &str) -> Option<f64> {
    ms_of(files, "online-culling", |r| {
        str_of(r, "sequence").starts_with("balls")
            && str_of(r, "order") == order
            && str_of(r, "config") == "kplus-semiheap + temporal"
    })
}

pub fn claims() -> Vec<Claim> {
    vec![
        Claim {
            seed: "002 Table 1",
            claim: "FABS over front-to-back peeling on the dragon: 363 vs 29 fps (ours: realtime, f2b ms / abuffer-fixed ms)",
            paper: 363.0 / 29.0,
            ours: |f| ratio(dragon(f, "f2b"), dragon(f, "abuffer-fixed")),
        },
        Claim {
            seed: "002 Table 1",
            claim: "FABS over dual peeling on the dragon: 363 vs 40 fps (ours: realtime, dual / abuffer-fixed)",
            paper: 363.0 / 40.0,
            ours: |f| ratio(dragon(f, "dual"), dragon(f, "abuffer-fixed")),
        },
        Claim {
            seed: "002 Table 1",
            claim: "FABS over MDTS on the dragon: 363 vs 297 fps (ours: cuda-renderer, compute MDTS / compute FABS)",
            paper: 363.0 / 297.0,
            ours: |f| {
                f.get("cuda-renderer")?
                    .get("ratios")?
                    .as_array()?
                    .iter()
                    .find(|r| str_of(r, "scene") == "builtin:dragon")
                    .and_then(|r| num(r, "mdts_over_fabs"))
            },
        },
        Claim {
            seed: "003 Fig. 6",
            claim: "k = 64, 128 layers: K+B-Heap 3.5× faster than KB-PS (ours: kbuffer-k, kb-ps / kplus-heap)",
            paper: 3.5,
            ours: |f| ratio(at_k64(f, "kb-ps"), at_k64(f, "kplus-heap")),
        },
        Claim {
            seed: "003 Fig. 6",
            claim: "k = 64, 128 layers: K+B-Heap 4× faster than KB-MDT32 (ours: kbuffer-k, kb-mdt32 / kplus-heap)",
            paper: 4.0,
            ours: |f| ratio(at_k64(f, "kb-mdt32"), at_k64(f, "kplus-heap")),
        },
        Claim {
            seed: "001 Table 1",
            claim: "up to 9.28× faster than depth peeling (ours: convex, the largest f2b / convex over models and layered spheres)",
            paper: 9.28,
            ours: |f| {
                f.get("convex")?
                    .get("speedups")?
                    .as_array()?
                    .iter()
                    .filter_map(|r| num(r, "f2b_over_convex"))
                    .max_by(f64::total_cmp)
            },
        },
        Claim {
            seed: "001 §5",
            claim: "memory of MDTS at 60 layers over convex: 240 vs 16 MB (ours: convex, kb-mdt32 / convex bytes on the deepest layered spheres)",
            paper: 240.0 / 16.0,
            ours: |f| {
                let depth: Vec<&Value> = rows(f, "convex")
                    .into_iter()
                    .filter(|r| str_of(r, "table") == "depth")
                    .collect();
                let layers = |r: &Value| {
                    str_of(r, "scene")
                        .split(['?', '&'])
                        .find_map(|p| p.strip_prefix("layers=")?.parse::<u32>().ok())
                };
                let deepest = depth.iter().filter_map(|r| layers(r)).max()?;
                let bytes = |m: &str| {
                    depth
                        .iter()
                        .find(|r| layers(r) == Some(deepest) && str_of(r, "method") == m)
                        .and_then(|r| num(r, "bytes_allocated"))
                };
                ratio(bytes("kb-mdt32"), bytes("convex"))
            },
        },
        Claim {
            seed: "000 Table 1",
            claim: "online culling, random triangle order, within 1–28% of the best (front-to-back) order: paper's worst case 1.28 (ours: online-culling balls, semi-heap + temporal, random / front)",
            paper: 1.28,
            ours: |f| ratio(online(f, "random"), online(f, "front")),
        },
        Claim {
            seed: "000 Table 1",
            claim: "online culling 12–55% faster than the worst (back-to-front) order: paper's best case 1.55 (ours: back / random)",
            paper: 1.55,
            ours: |f| ratio(online(f, "back"), online(f, "random")),
        },
        Claim {
            seed: "004 Table 1",
            claim: "compressed G-buffer over the traditional one: 8.25 vs 20.25 MB at 1024×768 (ours: deferred-lights layouts, bytes per pixel)",
            paper: 8.25 / 20.25,
            ours: |f| {
                let layouts = f.get("deferred-lights")?.get("layouts")?.as_array()?;
                let bytes = |prefix: &str| {
                    layouts
                        .iter()
                        .find(|l| str_of(l, "layout").starts_with(prefix))
                        .and_then(|l| num(l, "bytes_per_pixel"))
                };
                ratio(bytes("compressed"), bytes("traditional"))
            },
        },
    ]
}

/// The claims table: a column of our figure per device and of ours / paper.
pub fn table(devices: &[(String, bool, DeviceFiles)]) -> String {
    let mut s = String::from("| seed | claim | paper |");
    for (device, cpu, _) in devices {
        let cpu = if *cpu { " (CPU figures)" } else { "" };
        s += &format!(" {device}{cpu} | ours / paper |");
    }
    s += "\n|---|---|---|";
    s += &"---|---|".repeat(devices.len());
    s += "\n";
    for c in claims() {
        s += &format!("| {} | {} | {:.2} |", c.seed, c.claim, c.paper);
        for (_, _, files) in devices {
            match (c.ours)(files) {
                Some(v) => s += &format!(" {v:.2} | {:.2} |", v / c.paper),
                None => s += " | |",
            }
        }
        s += "\n";
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn claims_read_their_experiments_and_leave_missing_ones_empty() {
        let mut files = DeviceFiles::new();
        files.insert(
            "realtime".into(),
            json!({"results": [
                {"scene": "builtin:dragon", "method": "f2b", "median_gpu_ms": 100.0},
                {"scene": "builtin:dragon", "method": "abuffer-fixed", "median_gpu_ms": 8.0},
                {"scene": "builtin:nvpro", "method": "abuffer-fixed", "median_gpu_ms": 1.0},
            ]}),
        );
        files.insert(
            "online-culling".into(),
            json!({"rows": [
                {"sequence": "balls?count=9", "order": "front", "config": "kplus-semiheap + temporal", "gpu_ms": 10.0},
                {"sequence": "balls?count=9", "order": "random", "config": "kplus-semiheap + temporal", "gpu_ms": 11.0},
                {"sequence": "balls?count=9", "order": "random", "config": "kplus-semiheap + temporal", "gpu_ms": 13.0},
                {"sequence": "balls?count=9", "order": "random", "config": "kplus-heap, no culling", "gpu_ms": 99.0},
                {"sequence": "balls?count=9", "order": "back", "config": "kplus-semiheap + temporal", "gpu_ms": 18.0},
            ]}),
        );
        let all = claims();
        let by = |text: &str| all.iter().find(|c| c.claim.contains(text)).unwrap();
        assert_eq!((by("363 vs 29").ours)(&files), Some(12.5));
        assert_eq!((by("within 1–28%").ours)(&files), Some(1.2));
        assert_eq!((by("12–55%").ours)(&files), Some(1.5));
        assert_eq!((by("363 vs 40").ours)(&files), None);
        let table = table(&[
            ("gpu".into(), false, files),
            ("none".into(), true, DeviceFiles::new()),
        ]);
        assert!(table.contains("| 12.50 | 1.00 | | |"), "{table}");
        assert!(table.contains("none (CPU figures)"), "{table}");
    }
}
