//! `strata methods`: the method table as a catalogue.

use strata::error::{Error, Result};
use strata::methods;

/// `strata methods --backend NAME`: whether each method runs on that backend.
pub fn backend_table(name: &str, json: bool) -> Result<()> {
    use strata::methods::backends::{self, Backend};
    if name == "all" {
        print!("{}", backends::markdown_table());
        return Ok(());
    }
    let backend = Backend::parse(name)?;
    let offer = backends::offer_here(backend);
    let rows: Vec<(&methods::Descriptor, backends::Verdict)> = methods::catalogue()
        .map(|d| (d, backends::verdict(d, &offer)))
        .collect();
    let source = match &offer.adapter {
        Some(adapter) => format!("measured on this machine's adapter '{adapter}'"),
        None => "from wgpu 30's documented features (no adapter of it on this machine)".into(),
    };
    if json {
        let entries: Vec<serde_json::Value> = rows
            .iter()
            .map(|(d, v)| {
                serde_json::json!({
                    "id": d.name,
                    "runs": v.runs(),
                    "verdict": v.to_string(),
                })
            })
            .collect();
        let doc = serde_json::json!({
            "backend": backend.name(),
            "source": source,
            "measured": offer.measured(),
            "msaa": offer.sample_mask,
            "methods": entries,
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&doc).map_err(|e| Error::runtime(e.to_string()))?
        );
        return Ok(());
    }
    let runs = rows.iter().filter(|(_, v)| v.runs()).count();
    println!(
        "{backend}: {runs} of {} methods run ({source}){}",
        rows.len(),
        if offer.sample_mask {
            ""
        } else {
            "; no --msaa here (naga's GLSL output cannot read @builtin(sample_mask))"
        }
    );
    let wi = rows.iter().map(|(d, _)| d.name.len()).max().unwrap_or(0);
    for (d, v) in &rows {
        println!("{:<wi$}  {v}", d.name);
    }
    Ok(())
}

/// `strata methods`: the catalogue as columns, as JSON, or (`markdown`) as the README's table.
pub fn list_methods(json: bool, markdown: bool) -> Result<()> {
    if markdown {
        print!("{}", methods::markdown_table());
        return Ok(());
    }
    let all: Vec<&methods::Descriptor> = methods::catalogue().collect();
    if json {
        let entries: Vec<serde_json::Value> = all
            .iter()
            .map(|m| {
                let mut v = serde_json::to_value(m).unwrap_or_default();
                v["raster"] = m.rasters().split(',').collect::<Vec<_>>().into();
                v["msaa"] = m.msaa_counts().into();
                v["app_shaders"] = m.app_shaders.yes().into();
                if let methods::Support::No(why) = m.app_shaders {
                    v["app_shaders_why_not"] = why.into();
                }
                v["blend"] = match m.blend_modes {
                    methods::Support::Yes => vec!["over", "add", "multiply"].into(),
                    methods::Support::No(_) => vec!["over"].into(),
                };
                v
            })
            .collect();
        println!(
            "{}",
            serde_json::to_string_pretty(&entries).map_err(|e| Error::runtime(e.to_string()))?
        );
        return Ok(());
    }
    let width =
        |f: &dyn Fn(&methods::Descriptor) -> usize| all.iter().map(|m| f(m)).max().unwrap_or(0);
    let (wi, wf, wp, wm) = (
        width(&|m| m.name.len()),
        width(&|m| m.family.name().len()),
        width(&|m| m.geometry_passes.chars().count()),
        width(&|m| m.memory.chars().count()),
    );
    println!(
        "{:<wi$}  {:<wf$}  exact  {:<10}  {:<5}  blend  app shaders  {:<wp$}  {:<wm$}  summary",
        "id", "family", "raster", "msaa", "geometry passes", "memory (bytes)"
    );
    for m in &all {
        let msaa: Vec<String> = m.msaa_counts().iter().map(u32::to_string).collect();
        println!(
            "{:<wi$}  {:<wf$}  {:<5}  {:<10}  {:<5}  {:<5}  {:<11}  {:<wp$}  {:<wm$}  {}",
            m.name,
            m.family.name(),
            if m.exact { "yes" } else { "no" },
            m.rasters(),
            msaa.join(","),
            m.blend_names(),
            if m.app_shaders.yes() { "yes" } else { "no" },
            m.geometry_passes,
            m.memory,
            m.summary
        );
    }
    Ok(())
}
