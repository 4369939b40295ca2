//! Frames in flight: one command buffer and fence per slot.
//!
//! Invariants: [`Frames::begin`] waits for the slot's previous submission before it resets the command
//! buffer, and tells the release queue (`gpu::lifetime`) that the submission is complete, so whatever was
//! dropped before it is destroyed then. Objects dropped while a frame is being recorded stay pinned until that
//! frame is submitted. A frame begun and never submitted (an error between `begin` and `submit`) is abandoned
//! by the next `begin` or by dropping the ring. The fences and the command pool release themselves.
use super::context::Context;
use super::lifetime::{DeviceShared, Owned};
use crate::error::{Error, Result, VkContext};
use ash::vk;
use std::sync::Arc;

struct Slot {
    cmd: vk::CommandBuffer,
    fence: Owned<vk::Fence>,
    /// Serial of the slot's last submission, if it has not been waited for yet.
    in_flight: Option<u64>,
}

/// A ring of frame slots.
pub struct Frames {
    slots: Vec<Slot>,
    current: usize,
    recording: bool,
    frame_number: u64,
    shared: Arc<DeviceShared>,
    // Last: the command buffers are freed with the pool.
    _pool: Owned<vk::CommandPool>,
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
        let pool = ctx.own(pool, "frame command pool");
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool.raw())
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(count.max(1) as u32);
        // SAFETY: valid pool.
        let cmds = unsafe { ctx.device.allocate_command_buffers(&alloc) }
            .vk("vkAllocateCommandBuffers")?;
        let mut slots = Vec::new();
        for (i, cmd) in cmds.into_iter().enumerate() {
            // SAFETY: valid device.
            let fence = unsafe {
                ctx.device
                    .create_fence(&vk::FenceCreateInfo::default(), None)
            }
            .vk("vkCreateFence")?;
            ctx.set_name(cmd, &format!("frame {i} commands"));
            slots.push(Slot {
                cmd,
                fence: ctx.own(fence, &format!("frame {i} fence")),
                in_flight: None,
            });
        }
        Ok(Frames {
            slots,
            current: 0,
            recording: false,
            frame_number: 0,
            shared: ctx.shared().clone(),
            _pool: pool,
        })
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

    /// Waits for the current slot's previous work (whatever was dropped before it is destroyed now) and
    /// starts recording. Returns the slot index and its command buffer.
    pub fn begin(&mut self, ctx: &Context) -> Result<(usize, vk::CommandBuffer)> {
        if self.recording {
            // The previous frame was begun and never submitted: its recording is abandoned.
            self.recording = false;
            self.shared.end_recording();
        }
        let slot = &mut self.slots[self.current];
        if let Some(serial) = slot.in_flight {
            // SAFETY: the fence belongs to this device.
            unsafe {
                ctx.device
                    .wait_for_fences(&[slot.fence.raw()], true, u64::MAX)
            }
            .vk("vkWaitForFences")?;
            // SAFETY: the fence is signalled and unused.
            unsafe { ctx.device.reset_fences(&[slot.fence.raw()]) }.vk("vkResetFences")?;
            slot.in_flight = None;
            self.shared.completed(serial);
        }
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
        self.shared.begin_recording();
        Ok((self.current, slot.cmd))
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
        self.recording = false;
        let slot = &mut self.slots[self.current];
        let result = (|| {
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
            let serial = self.shared.next_serial();
            // Counted as in flight even if the call fails: waiting on an unsignalled fence is avoided
            // below, and `Context::wait_idle` completes every serial.
            // SAFETY: valid queue, command buffer and fence (unsignalled).
            unsafe {
                ctx.device
                    .queue_submit(ctx.queue, &[submit], slot.fence.raw())
            }
            .vk("vkQueueSubmit")?;
            slot.in_flight = Some(serial);
            Ok(())
        })();
        self.shared.end_recording();
        result?;
        self.frame_number += 1;
        self.current = (self.current + 1) % self.slots.len();
        Ok(())
    }

    /// Waits for every submitted slot.
    pub fn wait_all(&mut self, ctx: &Context) -> Result<()> {
        let mut last = None;
        for slot in &mut self.slots {
            if let Some(serial) = slot.in_flight {
                // SAFETY: valid fence.
                unsafe {
                    ctx.device
                        .wait_for_fences(&[slot.fence.raw()], true, u64::MAX)
                }
                .vk("vkWaitForFences")?;
                last = last.max(Some(serial));
            }
        }
        if let Some(serial) = last {
            self.shared.completed(serial);
        }
        Ok(())
    }
}

impl Drop for Frames {
    fn drop(&mut self) {
        if self.recording {
            self.shared.end_recording();
        }
        // The fences and the pool go through the release queue: they are destroyed once the slots'
        // submissions are known to be complete.
    }
}
