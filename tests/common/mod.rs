//! The GPU test harness: every GPU test runs inside [`with_gpu`], which builds a context with the validation
//! layer (and synchronization validation) required, and fails the test on any validation message or any
//! GPU allocation still alive at the end.
#![allow(dead_code)]
use gregvox::gpu::{Context, ContextDesc, Validation};

/// A context with validation required.
pub fn validated_context() -> Context {
    Context::with_desc(&ContextDesc {
        validation: Validation::Required,
        sync_validation: true,
        ..Default::default()
    })
    .expect("a Vulkan device with the validation layer (see README: apt packages)")
}

/// Runs `f` with a validated context; then asserts no allocation is alive and no validation message came.
pub fn with_gpu<T>(f: impl FnOnce(&Context) -> T) -> T {
    let ctx = validated_context();
    let sink = ctx.validation.clone();
    let out = f(&ctx);
    // Everything the test dropped is destroyed once the device is idle; what is left was leaked.
    ctx.wait_idle().expect("vkDeviceWaitIdle");
    let live = ctx.live_allocations();
    drop(ctx);
    assert!(
        live.is_empty(),
        "GPU allocations still alive at the end of the test: {live:?}"
    );
    assert_eq!(
        sink.count(),
        0,
        "validation messages:\n{}",
        sink.messages().join("\n")
    );
    out
}

/// Path of a file in the repository's models folder (`assets/models`).
pub fn model(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets/models")
        .join(name)
}
