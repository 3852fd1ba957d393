//! `strata info`: the adapter and what it can do.

use strata::error::{Error, Result};
use strata::gpu::Gpu;

pub fn info(json: bool) -> Result<()> {
    let gpu = Gpu::new()?;
    let r = gpu.report();
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&r).map_err(|e| Error::runtime(e.to_string()))?
        );
        return Ok(());
    }
    println!("adapter   {}", r.adapter);
    println!("backend   {}", r.backend);
    println!("type      {}", r.device_type);
    println!("driver    {} {}", r.driver, r.driver_info);
    println!(
        "timestamp {}",
        r.timestamp_period_ns
            .map(|p| format!("{p} ns/tick"))
            .unwrap_or_else(|| "unsupported".into())
    );
    println!("features  {}", r.features.join(", "));
    println!("limits    {}", serde_json::json!(r.limits));
    Ok(())
}
