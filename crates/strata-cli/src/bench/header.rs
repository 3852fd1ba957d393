//! The header every experiment's results carry (device, driver, commit, time) and the
//! formatting helpers of their tables.

use super::*;

pub(crate) use strata::metrics::median;

pub(crate) fn commit() -> Option<String> {
    let out = std::process::Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

pub fn device_slug(gpu: &Gpu) -> String {
    let name = gpu.info.name.to_lowercase();
    if name.contains("llvmpipe") {
        return "lavapipe".into();
    }
    let slug: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    slug.split('-')
        .filter(|s| !s.is_empty())
        .collect::<Vec<_>>()
        .join("-")
}

/// Where and when figures were measured: every results file carries it (flattened into it).
#[derive(Clone, Serialize)]
pub(crate) struct Provenance {
    pub(crate) adapter: String,
    pub(crate) backend: String,
    pub(crate) device_type: String,
    pub(crate) driver: String,
    /// True when the adapter is a CPU (lavapipe): the figures measure a CPU, not a GPU.
    pub(crate) cpu_figures: bool,
    pub(crate) commit: Option<String>,
    pub(crate) unix_time: u64,
}

impl Provenance {
    pub(crate) fn new(gpu: &Gpu, cpu_figures: bool) -> Provenance {
        Provenance {
            adapter: gpu.info.name.clone(),
            backend: gpu.backend_name(),
            device_type: format!("{:?}", gpu.info.device_type),
            driver: format!("{} {}", gpu.info.driver, gpu.info.driver_info)
                .trim()
                .to_string(),
            cpu_figures,
            commit: commit(),
            unix_time: unix_time(),
        }
    }

    /// The adapter as a report's heading names it, marked when its figures are a CPU's.
    pub(crate) fn device(&self) -> String {
        format!(
            "{} ({}){}",
            self.adapter,
            self.backend,
            cpu_label(self.cpu_figures)
        )
    }
}

/// What every standalone experiment's results file starts with (flattened into it): the same
/// provenance as a frame-loop experiment's.
#[derive(Clone, Serialize)]
pub(crate) struct Header {
    pub(crate) experiment: &'static str,
    #[serde(flatten)]
    pub(crate) provenance: Provenance,
    /// The size of the pictures the experiment renders (convex: its models' pictures).
    pub(crate) width: u32,
    pub(crate) height: u32,
}

impl Header {
    pub(crate) fn new(
        experiment: &'static str,
        gpu: &Gpu,
        cpu_figures: bool,
        (width, height): (u32, u32),
    ) -> Header {
        Header {
            experiment,
            provenance: Provenance::new(gpu, cpu_figures),
            width,
            height,
        }
    }

    /// The adapter as a report's heading names it (see [`Provenance::device`]).
    pub(crate) fn device(&self) -> String {
        self.provenance.device()
    }

    /// The pictures' size as a heading writes it: WxH.
    pub(crate) fn size(&self) -> String {
        format!("{}x{}", self.width, self.height)
    }

    /// Prints the experiment's heading: "NAME on DEVICE: " and `details`.
    pub(crate) fn print_heading(&self, details: std::fmt::Arguments) {
        println!("{} on {}: {details}", self.experiment, self.device());
    }
}

pub(crate) fn unix_time() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0)
}

/// A number with `digits` decimals, or nothing (a table's empty cell).
pub(crate) fn fixed(v: Option<f64>, digits: usize) -> String {
    v.map(|v| format!("{v:.digits$}")).unwrap_or_default()
}

/// A value, or nothing (a table's empty cell).
pub(crate) fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map(|v| v.to_string()).unwrap_or_default()
}

/// The suffix of a report's heading whose figures come from a CPU adapter.
pub(crate) fn cpu_label(cpu_figures: bool) -> &'static str {
    if cpu_figures {
        " (CPU figures: lavapipe)"
    } else {
        ""
    }
}
