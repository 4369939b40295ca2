//! GPU object lifetime: every Vulkan object gregvox creates releases itself when its owner is dropped.
//!
//! Invariants:
//! - The instance, the device and the memory allocator live in one [`DeviceShared`], reference-counted.
//!   Every owning value ([`crate::gpu::Buffer`], [`crate::gpu::Image`], the pipelines, [`Owned`] handles,
//!   [`crate::gpu::Frames`], …) holds an `Arc` of it, so the device is destroyed only after the last object
//!   made from it: a drop can never reach a destroyed device, whatever the order of drops. A device lent by
//!   the caller (`Context::from_external`) is not destroyed at all: only gregvox's own objects are.
//! - Dropping an owner never destroys a handle the GPU may still use. It hands the handle to the release
//!   queue, stamped with the serial of the last queue submission that could reference it; the queue destroys
//!   it once that submission is known to be complete (a fence waited on by `Context::one_shot`,
//!   `Frames::begin`, `Context::wait_idle`, or, for work recorded into a caller's command buffers, the
//!   caller's timeline semaphore: `gpu::external`). Queue submissions complete in order (a fence signal covers all
//!   earlier submissions on the queue), so one "completed" serial is enough.
//! - A handle dropped while a command buffer is being recorded may be referenced by that recording, which has
//!   no serial yet: it is *pinned* until the submission that closes the last open recording, and stamped with
//!   that serial. Nested recordings (a one-shot inside an open frame) therefore keep it until the outer one is
//!   submitted.
//! - When nothing is in flight (`submitted == completed`) and nothing is being recorded, a dropped handle is
//!   destroyed at once, so code that waits for its own work (every one-shot path) frees memory immediately.
//! - The only ways to destroy a handle the GPU may be using are the `unsafe` `destroy_now` methods, whose
//!   `# Safety` sections state the promise the caller makes.
//!
//! This is the scheme of Granite's per-frame deletion lists and kajiya's deferred release, keyed by queue
//! serials instead of frame indices because gregvox mixes one-shot submissions with frames in flight.
use super::debug::ValidationSink;
use crate::error::{Error, Result};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, Allocator};
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// A Vulkan object waiting to be destroyed, with the memory it owns.
#[derive(Debug)]
pub enum Retired {
    Buffer(vk::Buffer, Option<Allocation>),
    Image(vk::Image, vk::ImageView, Option<Allocation>),
    ImageView(vk::ImageView),
    Pipeline(vk::Pipeline),
    PipelineLayout(vk::PipelineLayout),
    DescriptorSetLayout(vk::DescriptorSetLayout),
    DescriptorPool(vk::DescriptorPool),
    Sampler(vk::Sampler),
    QueryPool(vk::QueryPool),
    Fence(vk::Fence),
    Semaphore(vk::Semaphore),
    CommandPool(vk::CommandPool),
    Swapchain(vk::SwapchainKHR),
    Surface(vk::SurfaceKHR),
}

/// A handle type that [`Owned`] can release.
pub trait OwnedHandle: vk::Handle + Copy + std::fmt::Debug {
    /// The release-queue entry for this handle.
    fn retired(self) -> Retired;
}

macro_rules! owned_handle {
    ($($ty:ident),*) => {$(
        impl OwnedHandle for vk::$ty {
            fn retired(self) -> Retired {
                Retired::$ty(self)
            }
        }
    )*};
}
owned_handle!(
    ImageView,
    Pipeline,
    PipelineLayout,
    DescriptorSetLayout,
    DescriptorPool,
    Sampler,
    QueryPool,
    Fence,
    Semaphore,
    CommandPool
);

impl OwnedHandle for vk::SwapchainKHR {
    fn retired(self) -> Retired {
        Retired::Swapchain(self)
    }
}

impl OwnedHandle for vk::SurfaceKHR {
    fn retired(self) -> Retired {
        Retired::Surface(self)
    }
}

/// A Vulkan handle that is released (through the release queue) when dropped.
#[derive(Debug)]
pub struct Owned<H: OwnedHandle> {
    raw: H,
    shared: Arc<DeviceShared>,
}

impl<H: OwnedHandle> Owned<H> {
    /// Takes ownership of `raw`, created from the device of `shared`.
    pub(crate) fn new(shared: &Arc<DeviceShared>, raw: H) -> Self {
        Owned {
            raw,
            shared: shared.clone(),
        }
    }

    /// The raw handle (valid while `self` lives).
    pub fn raw(&self) -> H {
        self.raw
    }
}

impl<H: OwnedHandle> Drop for Owned<H> {
    fn drop(&mut self) {
        self.shared.release(self.raw.retired());
    }
}

#[derive(Debug, Default)]
struct ReleaseQueue {
    /// Serial of the last queue submission.
    submitted: u64,
    /// Highest serial known to be complete.
    completed: u64,
    /// Command buffers being recorded (begun, not yet submitted or abandoned).
    open_recordings: u32,
    /// Dropped while a recording was open: wait for the submission that closes the last one.
    pinned: Vec<Retired>,
    /// Stamped with the serial that must complete first.
    pending: Vec<(u64, Retired)>,
    /// Submissions of the caller's (a borrowed device): serial, and the timeline semaphore value that
    /// says it completed.
    external: Vec<(u64, vk::Semaphore, u64)>,
}

impl ReleaseQueue {
    /// Removes what may be destroyed now, in the order it was released (a swapchain's views before the
    /// swapchain, the swapchain before its surface: owners release in field order).
    fn take_complete(&mut self) -> Vec<Retired> {
        let completed = self.completed;
        let (done, waiting): (Vec<_>, Vec<_>) = std::mem::take(&mut self.pending)
            .into_iter()
            .partition(|(serial, _)| *serial <= completed);
        self.pending = waiting;
        done.into_iter().map(|(_, item)| item).collect()
    }
}

/// What every object made from one device shares: the instance, the device, the allocator, the memory
/// budget and the release queue. Destroyed when the last owner is dropped (see the module invariants).
pub struct DeviceShared {
    pub(crate) instance: ash::Instance,
    pub(crate) device: ash::Device,
    debug_utils: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    surface_instance: Option<ash::khr::surface::Instance>,
    swapchain_device: Option<ash::khr::swapchain::Device>,
    allocator: ManuallyDrop<Mutex<Allocator>>,
    allocated_bytes: AtomicU64,
    memory_budget: Option<u64>,
    queue: Mutex<ReleaseQueue>,
    validation: Arc<ValidationSink>,
    /// Whether the instance and the device are gregvox's to destroy (false: lent by the caller).
    owns_device: bool,
    // Keeps the loader library mapped until the instance is gone.
    _entry: ash::Entry,
}

impl std::fmt::Debug for DeviceShared {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DeviceShared")
            .field("device", &self.device.handle())
            .field("allocated_bytes", &self.allocated_bytes)
            .finish_non_exhaustive()
    }
}

/// The parts of a freshly created device that [`DeviceShared`] takes over.
pub(crate) struct DeviceParts {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    pub device: ash::Device,
    pub debug_utils: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    pub surface_instance: Option<ash::khr::surface::Instance>,
    pub swapchain_device: Option<ash::khr::swapchain::Device>,
    pub allocator: Allocator,
    pub memory_budget: Option<u64>,
    pub validation: Arc<ValidationSink>,
    pub owns_device: bool,
}

/// Validation messages received by devices of this process that have been destroyed (including the layer's
/// report of undestroyed objects, which arrives during `vkDestroyDevice`).
pub(crate) static VALIDATION_MESSAGES: AtomicU64 = AtomicU64::new(0);

impl DeviceShared {
    pub(crate) fn new(parts: DeviceParts) -> Arc<Self> {
        Arc::new(DeviceShared {
            instance: parts.instance,
            device: parts.device,
            debug_utils: parts.debug_utils,
            surface_instance: parts.surface_instance,
            swapchain_device: parts.swapchain_device,
            allocator: ManuallyDrop::new(Mutex::new(parts.allocator)),
            allocated_bytes: AtomicU64::new(0),
            memory_budget: parts.memory_budget,
            queue: Mutex::new(ReleaseQueue::default()),
            validation: parts.validation,
            owns_device: parts.owns_device,
            _entry: parts.entry,
        })
    }

    fn queue(&self) -> std::sync::MutexGuard<'_, ReleaseQueue> {
        self.queue.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Locks the allocator.
    pub(crate) fn allocator(&self) -> std::sync::MutexGuard<'_, Allocator> {
        self.allocator.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The allocation budget in bytes, if one is set.
    pub(crate) fn memory_budget(&self) -> Option<u64> {
        self.memory_budget
    }

    /// Bytes currently allocated (including objects waiting in the release queue).
    pub(crate) fn allocated_bytes(&self) -> u64 {
        self.allocated_bytes.load(Ordering::SeqCst)
    }

    /// Reserves `bytes` against the memory budget; fails with a clear error past it.
    pub(crate) fn reserve_bytes(&self, name: &str, bytes: u64) -> Result<()> {
        let before = self.allocated_bytes.fetch_add(bytes, Ordering::SeqCst);
        if let Some(budget) = self.memory_budget {
            if before + bytes > budget {
                self.allocated_bytes.fetch_sub(bytes, Ordering::SeqCst);
                return Err(Error::Alloc {
                    name: name.into(),
                    bytes,
                    reason: format!(
                        "over the memory budget of {budget} bytes ({before} in use; the budget comes from \
                         {} or ContextDesc::memory_budget)",
                        super::context::MEMORY_BUDGET_ENV
                    ),
                });
            }
        }
        Ok(())
    }

    /// Returns `bytes` to the memory budget.
    pub(crate) fn release_bytes(&self, bytes: u64) {
        self.allocated_bytes.fetch_sub(bytes, Ordering::SeqCst);
    }

    /// Hands `item` to the release queue (see the module invariants).
    pub(crate) fn release(&self, item: Retired) {
        let now = {
            let mut q = self.queue();
            if q.open_recordings > 0 {
                q.pinned.push(item);
                None
            } else if q.submitted <= q.completed {
                Some(item)
            } else {
                let serial = q.submitted;
                q.pending.push((serial, item));
                None
            }
        };
        if let Some(item) = now {
            // SAFETY: nothing is in flight and nothing is being recorded, so no command can reference it.
            unsafe { self.destroy(item) };
        }
    }

    /// A command buffer starts recording.
    pub(crate) fn begin_recording(&self) {
        self.queue().open_recordings += 1;
    }

    /// The serial for a submission about to be made.
    pub(crate) fn next_serial(&self) -> u64 {
        let mut q = self.queue();
        q.submitted += 1;
        q.submitted
    }

    /// A recording ends: submitted (its serial was taken with [`Self::next_serial`]) or abandoned. When no
    /// recording stays open, the pinned objects wait for the last submission.
    pub(crate) fn end_recording(&self) {
        let mut q = self.queue();
        q.open_recordings = q.open_recordings.saturating_sub(1);
        if q.open_recordings == 0 && !q.pinned.is_empty() {
            let serial = q.submitted;
            let pinned = std::mem::take(&mut q.pinned);
            q.pending
                .extend(pinned.into_iter().map(|item| (serial, item)));
        }
    }

    /// Submission `serial` (and every earlier one) is complete: destroys what waited for it.
    pub(crate) fn completed(&self, serial: u64) {
        let done = {
            let mut q = self.queue();
            q.completed = q.completed.max(serial);
            let c = q.completed;
            q.external.retain(|&(s, _, _)| s > c);
            q.take_complete()
        };
        for item in done {
            // SAFETY: the submissions that could reference it are complete.
            unsafe { self.destroy(item) };
        }
    }

    /// A recording into a caller's command buffer ends with its submission, which signals `semaphore` to
    /// `value` when complete (see `gpu::external`).
    pub(crate) fn external_submitted(&self, semaphore: vk::Semaphore, value: u64) {
        let serial = self.next_serial();
        self.queue().external.push((serial, semaphore, value));
        self.end_recording();
    }

    /// Reads the timeline semaphores of the caller's submissions and destroys what waited for those
    /// that completed.
    pub(crate) fn poll_external(&self) -> Result<()> {
        let waiting: Vec<(u64, vk::Semaphore, u64)> = self.queue().external.clone();
        let mut done = 0;
        for &(serial, semaphore, value) in &waiting {
            // SAFETY: the caller promised the semaphore is a live timeline semaphore of this device.
            let now = unsafe { self.device.get_semaphore_counter_value(semaphore) }.map_err(
                |result| Error::Vulkan {
                    call: "vkGetSemaphoreCounterValue",
                    result,
                },
            )?;
            if now >= value {
                done = done.max(serial);
            }
        }
        if done > 0 {
            self.queue().external.retain(|&(s, _, _)| s > done);
            self.completed(done);
        }
        Ok(())
    }

    /// The device is idle: every submission so far is complete.
    pub(crate) fn idle(&self) {
        let serial = self.queue().submitted;
        self.completed(serial);
    }

    /// Whether the instance and the device are gregvox's to destroy.
    pub(crate) fn owns_device(&self) -> bool {
        self.owns_device
    }

    /// Objects waiting in the release queue (pending and pinned).
    pub(crate) fn waiting(&self) -> usize {
        let q = self.queue();
        q.pending.len() + q.pinned.len()
    }

    /// Destroys everything queued, pinned included. Only when the device is idle and no recorded command
    /// buffer will be submitted any more (context destruction).
    fn release_everything(&self) {
        let items: Vec<Retired> = {
            let mut q = self.queue();
            let mut items: Vec<Retired> = q.pending.drain(..).map(|(_, i)| i).collect();
            items.append(&mut q.pinned);
            q.completed = q.submitted;
            q.external.clear();
            items
        };
        for item in items {
            // SAFETY: the caller's promise (idle device, no further submission of what referenced it).
            unsafe { self.destroy(item) };
        }
    }

    /// Waits for the device and destroys everything queued; see [`Self::release_everything`].
    pub(crate) fn shut_down_queue(&self) {
        // SAFETY: valid device.
        let _ = unsafe { self.device.device_wait_idle() };
        self.release_everything();
    }

    /// Destroys one object now.
    ///
    /// # Safety
    /// No command buffer that references `item` is pending or will be submitted.
    pub(crate) unsafe fn destroy(&self, item: Retired) {
        let d = &self.device;
        let free = |a: Option<Allocation>| {
            if let Some(a) = a {
                self.release_bytes(a.size());
                let _ = self.allocator().free(a);
            }
        };
        // SAFETY: the caller's promise; every handle was created from this device (or its instance) and is
        // owned by exactly one value, which gave it up.
        unsafe {
            match item {
                Retired::Buffer(b, a) => {
                    d.destroy_buffer(b, None);
                    free(a);
                }
                Retired::Image(i, v, a) => {
                    d.destroy_image_view(v, None);
                    d.destroy_image(i, None);
                    free(a);
                }
                Retired::ImageView(v) => d.destroy_image_view(v, None),
                Retired::Pipeline(p) => d.destroy_pipeline(p, None),
                Retired::PipelineLayout(l) => d.destroy_pipeline_layout(l, None),
                Retired::DescriptorSetLayout(l) => d.destroy_descriptor_set_layout(l, None),
                Retired::DescriptorPool(p) => d.destroy_descriptor_pool(p, None),
                Retired::Sampler(s) => d.destroy_sampler(s, None),
                Retired::QueryPool(p) => d.destroy_query_pool(p, None),
                Retired::Fence(f) => d.destroy_fence(f, None),
                Retired::Semaphore(s) => d.destroy_semaphore(s, None),
                Retired::CommandPool(p) => d.destroy_command_pool(p, None),
                Retired::Swapchain(s) => {
                    if let Some(sc) = &self.swapchain_device {
                        sc.destroy_swapchain(s, None);
                    }
                }
                Retired::Surface(s) => {
                    if let Some(si) = &self.surface_instance {
                        si.destroy_surface(s, None);
                    }
                }
            }
        }
    }

    /// Names and sizes of the GPU allocations alive now.
    pub(crate) fn live_allocations(&self) -> Vec<(String, u64)> {
        self.allocator()
            .generate_report()
            .allocations
            .into_iter()
            .map(|a| (a.name, a.size))
            .collect()
    }
}

impl Drop for DeviceShared {
    fn drop(&mut self) {
        // Every owner is gone: whatever is still queued can go, then the allocator (it frees its memory
        // blocks through the device), the device, the messenger and the instance, in that order; a lent
        // device and its instance stay, as the caller's.
        self.shut_down_queue();
        // SAFETY: nothing made from this device exists any more (every owner held an Arc of `self`).
        unsafe {
            ManuallyDrop::drop(&mut self.allocator);
            if self.owns_device {
                self.device.destroy_device(None);
            }
            // The layer reports undestroyed objects during vkDestroyDevice: count after it.
            VALIDATION_MESSAGES.fetch_add(self.validation.count() as u64, Ordering::SeqCst);
            if let Some((loader, messenger)) = self.debug_utils.take() {
                loader.destroy_debug_utils_messenger(messenger, None);
            }
            if self.owns_device {
                self.instance.destroy_instance(None);
            }
        }
    }
}
