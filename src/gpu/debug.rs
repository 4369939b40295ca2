//! The validation sink: a per-context record of every validation message.
//!
//! Invariants: the sink is owned by an `Arc` held by the `Context`; the debug-utils messenger receives a raw
//! pointer to it and is destroyed (in `Context::drop`) before the context's `Arc` is released, so the
//! pointer never dangles. Messages of type VALIDATION at WARNING or ERROR severity count as failures;
//! GENERAL messages (loader chatter) only go to the log.
use ash::vk;
use std::ffi::CStr;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Counts and keeps the validation messages of one context.
#[derive(Debug, Default)]
pub struct ValidationSink {
    count: AtomicUsize,
    messages: Mutex<Vec<String>>,
}

impl ValidationSink {
    /// Number of validation messages (warnings and errors) received so far.
    pub fn count(&self) -> usize {
        self.count.load(Ordering::SeqCst)
    }

    /// A copy of every message received so far.
    pub fn messages(&self) -> Vec<String> {
        self.messages.lock().map(|m| m.clone()).unwrap_or_default()
    }

    /// Records one message (also used by tests to check the sink itself).
    pub fn push(&self, msg: String) {
        self.count.fetch_add(1, Ordering::SeqCst);
        if let Ok(mut m) = self.messages.lock() {
            // Keep the first few hundred: a broken loop could otherwise exhaust memory.
            if m.len() < 512 {
                m.push(msg);
            }
        }
    }
}

/// The debug-utils callback. `user_data` points to the context's [`ValidationSink`].
pub(crate) unsafe extern "system" fn messenger_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    ty: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut std::ffi::c_void,
) -> vk::Bool32 {
    if data.is_null() {
        return vk::FALSE;
    }
    // SAFETY: the layer passes a valid callback-data struct for the duration of the call.
    let data = unsafe { &*data };
    let text = if data.p_message.is_null() {
        String::from("(no message)")
    } else {
        // SAFETY: p_message is a NUL-terminated string owned by the layer.
        unsafe { CStr::from_ptr(data.p_message) }
            .to_string_lossy()
            .into_owned()
    };
    let counts = ty.intersects(
        vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
            | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
    ) && severity.intersects(
        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
            | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
    );
    if counts {
        log::error!("vulkan validation: {text}");
        if !user_data.is_null() {
            // SAFETY: see the module invariants; the sink outlives the messenger.
            let sink = unsafe { &*(user_data as *const ValidationSink) };
            sink.push(text);
        }
    } else if ty.contains(vk::DebugUtilsMessageTypeFlagsEXT::GENERAL) {
        // Loader chatter ("Found no drivers!") duplicates the error gregvox reports itself.
        log::info!("vulkan: {text}");
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        log::error!("vulkan: {text}");
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
        log::warn!("vulkan: {text}");
    } else {
        log::debug!("vulkan: {text}");
    }
    vk::FALSE
}
