//! Frames in flight: one command buffer, fence and deferred-destruction list per slot.
//!
//! Invariants: [`Frames::begin`] waits for the slot's previous submission before it resets the command
//! buffer and destroys what was deferred in that slot, so a resource handed to [`Frames::defer`] is destroyed
//! only once the GPU can no longer use it. [`Frames::destroy`] waits for every slot.
use super::context::Context;
use super::resources::{Deferred, DeferredDestroy};
use crate::error::{Error, Result, VkContext};
use ash::vk;

struct Slot {
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    deferred: DeferredDestroy,
    submitted: bool,
}

/// A ring of frame slots.
pub struct Frames {
    pool: vk::CommandPool,
    slots: Vec<Slot>,
    current: usize,
    recording: bool,
    frame_number: u64,
}

impl Frames {
    /// `count` frames in flight (2 is typical).
    pub fn new(ctx: &Context, count: usize) -> Result<Self> {
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid create info.
        let pool =
            unsafe { ctx.device.create_command_pool(&info, None) }.vk("vkCreateCommandPool")?;
        let mut frames = Frames {
            pool,
            slots: Vec::new(),
            current: 0,
            recording: false,
            frame_number: 0,
        };
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(count.max(1) as u32);
        // SAFETY: valid pool.
        let cmds = match unsafe { ctx.device.allocate_command_buffers(&alloc) } {
            Ok(c) => c,
            Err(result) => {
                frames.destroy(ctx);
                return Err(Error::Vulkan {
                    call: "vkAllocateCommandBuffers",
                    result,
                });
            }
        };
        for (i, cmd) in cmds.into_iter().enumerate() {
            let fi = vk::FenceCreateInfo::default();
            // SAFETY: valid device.
            let fence = match unsafe { ctx.device.create_fence(&fi, None) } {
                Ok(f) => f,
                Err(result) => {
                    frames.destroy(ctx);
                    return Err(Error::Vulkan {
                        call: "vkCreateFence",
                        result,
                    });
                }
            };
            ctx.set_name(cmd, &format!("frame {i} commands"));
            ctx.set_name(fence, &format!("frame {i} fence"));
            frames.slots.push(Slot {
                cmd,
                fence,
                deferred: DeferredDestroy::default(),
                submitted: false,
            });
        }
        Ok(frames)
    }

    /// Number of slots.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Whether there are no slots (never, once built).
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// The slot the next `begin` uses / the current one between `begin` and `submit`.
    pub fn slot(&self) -> usize {
        self.current
    }

    /// Frames submitted so far.
    pub fn frame_number(&self) -> u64 {
        self.frame_number
    }

    /// Waits for the current slot's previous work, destroys its deferred resources and starts recording.
    /// Returns the slot index and its command buffer.
    pub fn begin(&mut self, ctx: &Context) -> Result<(usize, vk::CommandBuffer)> {
        let slot = &mut self.slots[self.current];
        if slot.submitted {
            // SAFETY: the fence belongs to this device.
            unsafe { ctx.device.wait_for_fences(&[slot.fence], true, u64::MAX) }
                .vk("vkWaitForFences")?;
            // SAFETY: the fence is signalled and unused.
            unsafe { ctx.device.reset_fences(&[slot.fence]) }.vk("vkResetFences")?;
            slot.submitted = false;
        }
        slot.deferred.flush(ctx);
        // SAFETY: the command buffer's previous submission has completed.
        unsafe {
            ctx.device
                .reset_command_buffer(slot.cmd, vk::CommandBufferResetFlags::empty())
                .vk("vkResetCommandBuffer")?;
            let begin = vk::CommandBufferBeginInfo::default()
                .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            ctx.device
                .begin_command_buffer(slot.cmd, &begin)
                .vk("vkBeginCommandBuffer")?;
        }
        self.recording = true;
        Ok((self.current, slot.cmd))
    }

    /// Queues a resource for destruction once the current slot's work has completed.
    pub fn defer(&mut self, item: Deferred) {
        self.slots[self.current].deferred.push(item);
    }

    /// Ends recording and submits the current slot, waiting on `wait` semaphores (with their stages) and
    /// signalling `signal`; then moves to the next slot.
    pub fn submit(
        &mut self,
        ctx: &Context,
        wait: &[(vk::Semaphore, vk::PipelineStageFlags)],
        signal: &[vk::Semaphore],
    ) -> Result<()> {
        if !self.recording {
            return Err(Error::Invalid(
                "Frames::submit without Frames::begin".into(),
            ));
        }
        let slot = &mut self.slots[self.current];
        self.recording = false;
        // SAFETY: the command buffer is recording (begun by `begin`).
        unsafe { ctx.device.end_command_buffer(slot.cmd) }.vk("vkEndCommandBuffer")?;
        let wait_sems: Vec<vk::Semaphore> = wait.iter().map(|w| w.0).collect();
        let wait_stages: Vec<vk::PipelineStageFlags> = wait.iter().map(|w| w.1).collect();
        let cmds = [slot.cmd];
        let submit = vk::SubmitInfo::default()
            .wait_semaphores(&wait_sems)
            .wait_dst_stage_mask(&wait_stages)
            .command_buffers(&cmds)
            .signal_semaphores(signal);
        // SAFETY: valid queue, command buffer and fence (unsignalled).
        unsafe { ctx.device.queue_submit(ctx.queue, &[submit], slot.fence) }.vk("vkQueueSubmit")?;
        slot.submitted = true;
        self.frame_number += 1;
        self.current = (self.current + 1) % self.slots.len();
        Ok(())
    }

    /// Waits for every submitted slot.
    pub fn wait_all(&mut self, ctx: &Context) -> Result<()> {
        for slot in &mut self.slots {
            if slot.submitted {
                // SAFETY: valid fence.
                unsafe { ctx.device.wait_for_fences(&[slot.fence], true, u64::MAX) }
                    .vk("vkWaitForFences")?;
            }
        }
        Ok(())
    }

    /// Waits for all work, destroys the deferred resources, fences and command pool.
    pub fn destroy(mut self, ctx: &Context) {
        let _ = ctx.wait_idle();
        for slot in &mut self.slots {
            slot.deferred.flush(ctx);
            // SAFETY: idle device.
            unsafe { ctx.device.destroy_fence(slot.fence, None) };
        }
        // SAFETY: idle device; destroying the pool frees its command buffers.
        unsafe { ctx.device.destroy_command_pool(self.pool, None) };
    }
}
