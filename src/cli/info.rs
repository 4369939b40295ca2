//! `gregvox info`: the chosen device, its driver and API version, the limits gregvox depends on, timestamp
//! support and the validation layer's presence (`--json` for machines).
use crate::api::{DeviceInfo, Gpu};
use clap::Args;

/// Arguments of `gregvox info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Runs `gregvox info`.
pub fn run(args: &InfoArgs) -> anyhow::Result<()> {
    let gpu = Gpu::new()?;
    let info = gpu.info().clone();
    if args.json {
        super::print_out(&format!("{}\n", serde_json::to_string_pretty(&info)?))?;
    } else {
        super::print_out(&format_info(&info))?;
    }
    // Fails on a validation message while probing the device.
    gpu.finish()?;
    Ok(())
}

fn mib(b: u64) -> String {
    format!("{:.0} MiB", b as f64 / (1024.0 * 1024.0))
}

/// The human-readable report.
pub fn format_info(i: &DeviceInfo) -> String {
    let c = i.max_compute_work_group_count;
    let s = i.max_compute_work_group_size;
    let f = &i.features;
    let yes = |b: bool| if b { "yes" } else { "no" };
    format!(
        "device            {} ({})\n\
         driver            {} — {}\n\
         Vulkan API        {}\n\
         vendor / device   {:#06x} / {:#06x}\n\
         \n\
         limits\n\
         max storage buffer range     {} bytes ({})\n\
         max compute workgroup count  {} × {} × {}\n\
         max compute workgroup size   {} × {} × {} ({} invocations)\n\
         max compute shared memory    {} bytes\n\
         max 2D image size            {}\n\
         max image array layers       {}\n\
         max push constants           {} bytes\n\
         subgroup size                {}\n\
         device-local heap            {}\n\
         memory types                 {}\n\
         \n\
         timestamps        {} (period {} ns, {} valid bits)\n\
         features          tessellation {}, geometry {}, fragment stores {}, wireframe {}, int64 {}, float64 {}\n\
         validation layer  {} ({})\n",
        i.name,
        i.device_type,
        i.driver_name,
        i.driver_info,
        i.api_version,
        i.vendor_id,
        i.device_id,
        i.max_storage_buffer_range,
        mib(i.max_storage_buffer_range as u64),
        c[0],
        c[1],
        c[2],
        s[0],
        s[1],
        s[2],
        i.max_compute_work_group_invocations,
        i.max_compute_shared_memory_size,
        i.max_image_dimension_2d,
        i.max_image_array_layers,
        i.max_push_constants_size,
        i.subgroup_size,
        mib(i.device_local_heap_bytes),
        i.memory_types,
        if i.timestamps_supported { "supported" } else { "not supported" },
        i.timestamp_period_ns,
        i.timestamp_valid_bits,
        yes(f.tessellation_shader),
        yes(f.geometry_shader),
        yes(f.fragment_stores_and_atomics),
        yes(f.fill_mode_non_solid),
        yes(f.shader_int64),
        yes(f.shader_float64),
        if i.validation_layer_present { "present" } else { "absent" },
        if i.validation_enabled { "enabled" } else { "not enabled" },
    )
}
