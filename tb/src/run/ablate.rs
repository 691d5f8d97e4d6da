//! What a conclusion rests on: the headline speed-ups over RB_8 with each simulator mechanism
//! turned off in turn, the engine behind `sms ablate`.
//!
//! ```text
//!   reference (everything as requested) + one arm per mechanism (that mechanism off)
//!        │  sweep::run_arms: scenes outer, so each scene is loaded once; arms with equal
//!        ▼  workloads share one
//!   one Sweep per arm (RB_8 and the headline configurations on the base L1D)
//!        │
//!        ▼
//!   table: rows = arm, columns = configuration (speed-up geomean, delta vs the reference);
//!   per scene; chart (drawn by crate::report::ablate)
//! ```
//!
//! A mechanism is one entry of [`MECHANISMS`]: a name, a one-line description with its source,
//! what "off" means and a function that turns it off. Adding a mechanism is adding one entry.

use crate::error::{Error, Result};
use crate::run::sim::Hardware;
use crate::run::sweep::{Plan, Request, Sweep, Tweak};
use crate::workload::scene::SceneLibrary;
use crate::workload::traverse::ChildOrder;
use crate::workload::{PathEnd, WorkloadOpts};

/// One switchable simulator mechanism.
#[derive(Clone, Copy, Debug)]
pub struct Mechanism {
    /// Short name (report rows, chart labels).
    pub name: &'static str,
    /// What the mechanism models, with its source.
    pub what: &'static str,
    /// What the simulator does with it off.
    pub off_means: &'static str,
    /// Turns it off.
    pub off: Tweak,
}

/// Every mechanism the ablation turns off, in report order. "Off" is always the simpler
/// assumption the model can make instead (the `legacy` preset's value, or the reduced
/// workload), so each row says what one simulator assumption is worth.
pub const MECHANISMS: &[Mechanism] = &[
    Mechanism {
        name: "blocking-stack",
        what: "stack requests on the ray's critical path: the next node fetch waits for the thread's stack \
               sequencer, global stores complete at the L2's acknowledgement (the paper's RT unit; SPEC 3; \
               vulkan-sim shader.cc ~3090 retires a warp only without pending writes)",
        off_means: "overlapped: posted stores, the refill runs beside the next node fetch",
        off: |hw, _| hw.stack.timing = rtl::rt_unit::StackTiming::Overlapped,
    },
    Mechanism {
        name: "acked-stores",
        what: "every stack store holds the thread's next node fetch, a global store until the L2 acknowledges \
               it (the preset's reading of the paper's sequence, §VI-A; docs/assumptions.md)",
        off_means: "posted: only loads hold the fetch; global stores need no acknowledgement (Vulkan-Sim's \
                    store queue, shader.cc:2982-2997, 3090)",
        off: |hw, _| hw.stack.store_gating = rtl::rt_unit::StoreGating::Posted,
    },
    Mechanism {
        name: "acked-sh-stores",
        what: "SH stores hold the thread's next node fetch like every other stack request (docs/assumptions.md)",
        off_means: "sh-posted: SH stores complete behind the fetch; global stores still wait for their ack",
        off: |hw, _| hw.stack.store_gating = rtl::rt_unit::StoreGating::ShPosted,
    },
    Mechanism {
        name: "unbounded-store-queue",
        what: "posted global stores queue without bound, as Vulkan-Sim's RT store queue (shader.h:1344); \
               the arm posts stores, so the bound has something to hold",
        off_means: "posted stores, and no stack command taken while 16 stores wait for the port (the depth of \
                    MOBILE's L1D miss queue, gpgpusim.config:101; no source gives the stack's)",
        off: |hw, _| {
            hw.stack.store_gating = rtl::rt_unit::StoreGating::Posted;
            hw.stack.store_queue = 16;
        },
    },
    Mechanism {
        name: "stack-port-first",
        what: "the stack's requests take the RT unit's memory port before node fetches (the paper does not say)",
        off_means: "Vulkan-Sim's order: the node fetch under way, then stack requests, then a new warp \
                    (rt_unit::memory_cycle, shader.cc:3237-3254; cycle, 3040-3061)",
        off: |hw, _| hw.stack.port_priority = rtl::rt_unit::PortPriority::Node,
    },
    Mechanism {
        name: "gto",
        what: "the RT unit's warp scheduler is greedy-then-oldest (the paper, §II-B)",
        off_means: "the oldest ready warp at every pick (Vulkan-Sim's schedule_next_warp, shader.cc:3217-3230)",
        off: |hw, _| hw.rt.warp_select = rtl::rt_unit::WarpSelect::Oldest,
    },
    Mechanism {
        name: "sh-latency",
        what: "shared-memory (SH) accesses take Vulkan-Sim's 20-cycle shared-memory latency after bank \
               serialisation (MOBILE gpgpusim.config:108 -gpgpu_smem_latency 20)",
        off_means: "2 cycles: issue, bank grant, done",
        off: |hw, _| hw.stack.sh_latency = rtl::bank_arbiter::MIN_SH_LATENCY,
    },
    Mechanism {
        name: "address-map",
        what: "GPGPU-Sim's address mapping: local memory interleaved across threads (shader.cc:2029 \
               translate_local_memaddr), L2 slices by 256-byte chunks (dramid@8), IPOLY set index \
               (gpu-cache.cc:121-165)",
        off_means: "a private spill region per thread, L2 interleaved by line, set = line mod sets",
        off: |hw, _| {
            hw.mem.local_layout = rtl::mem::LocalLayout::Linear;
            hw.mem.l2_set_index = rtl::mem::SetIndex::Linear;
            hw.mem.l2_interleave_bytes = hw.mem.line_bytes;
        },
    },
    Mechanism {
        name: "rt-l1d",
        what: "the L1D as Vulkan-Sim's RT unit uses it: write-evict, no write-allocate (dl1 L:L:s:N, \
               gpu-cache.cc:1295-1305, 1559), streaming with 4096 MSHRs merging 64 and a 16-entry miss \
               queue (gpu-cache.h:548-566), hits used in the cycle after the lookup (shader.cc:3557)",
        off_means: "write-through (a store hit updates), 32 MSHRs merging 8, miss queue 8, 20-cycle hits",
        off: |hw, _| {
            hw.mem.l1d_write = rtl::mem::L1dWrite::WriteThrough;
            (hw.mem.l1d_mshrs, hw.mem.l1d_mshr_merge, hw.mem.l1d_miss_queue) = (32, 8, 8);
            hw.mem.l1d_hit_latency = 20;
        },
    },
    Mechanism {
        name: "two-level",
        what: "a TLAS over one BLAS per object or glTF mesh, 128-byte instance leaves, one stack across both \
               levels (vulkan_ray_tracing.cc:540-1100; RayTracingInVulkan builds one BLAS per model)",
        off_means: "one flat BVH over every primitive",
        off: |_, w| w.accel = crate::workload::Accel::Flat,
    },
    Mechanism {
        name: "child-order",
        what: "Vulkan-Sim's child order: hit children in index order, the first hit internal child descended, \
               every other hit child pushed, leaves included (vulkan_ray_tracing.cc:648-675, 'TODO: sort by \
               thit')",
        off_means: "nearest hit child first, the others pushed far to near",
        off: |_, w| w.order = ChildOrder::Nearest,
    },
    Mechanism {
        name: "lumibench",
        what: "LumiBench's workload: 128x128 pixels, 2 spp, 16 rays per path, a hit on a surface's back ends \
               the path (RayTracingInVulkan lumibench.sh, src/Options.cpp:22, assets/shaders/Scatter.glsl:17, \
               RayTracing.rgen:71-75)",
        off_means: "a reduced workload: 3/4 of the resolution (96x96 at \
                    LumiBench's), 1 spp, 2 bounces, every hit scatters",
        off: |_, w| {
            (w.width, w.height) = ((w.width * 3 / 4).max(1), (w.height * 3 / 4).max(1));
            (w.spp, w.max_bounces) = (1, 2);
            w.path_end = PathEnd::Always;
        },
    },
];

/// The configurations whose speed-up over RB_8 the paper's conclusions rest on, with the short
/// names the report uses.
pub const HEADLINE: [(&str, &str); 7] = [
    ("RB_16", "RB_16"),
    ("RB_FULL", "RB_FULL"),
    ("RB_8+SH_8", "RB_8+SH_8"),
    ("RB_8+SH_8+SK", "+SK"),
    ("RB_8+SH_8+SK+RA", "SMS"),
    ("RB_2", "RB_2"),
    ("RB_2+SH_8+SK+RA", "RB_2+SMS"),
];

/// The plan of every arm: RB_8 (always run) and the headline configurations on the base L1D.
pub fn plan() -> Result<Plan> {
    let configs = HEADLINE
        .iter()
        .map(|(c, _)| c.parse().map_err(|e| Error::Invalid(format!("{c}: {e}"))))
        .collect::<Result<_>>()?;
    Ok(Plan { configs, rb_sizes: Vec::new(), l1d_kb: Vec::new() })
}

/// Whether turning `m` off changes the hardware or the workload `opts` (a scene's, under the
/// reference settings). An entry that changes nothing would report its mechanism as irrelevant.
pub fn changes(m: &Mechanism, hw: &Hardware, opts: &WorkloadOpts) -> bool {
    let (mut h, mut o) = (*hw, *opts);
    (m.off)(&mut h, &mut o);
    h != *hw || o != *opts
}

/// A finished ablation: the reference and one sweep per mechanism.
pub struct Ablation {
    pub reference: Sweep,
    pub arms: Vec<(Mechanism, Sweep)>,
}

/// Runs the reference and every mechanism of `mechanisms` off. Each mechanism must change
/// something in the reference (checked on the settings applied to the default workload).
pub fn run(
    req: &Request,
    mechanisms: &[Mechanism],
    library: &SceneLibrary,
    progress: &crate::run::sweep::Progress,
) -> Result<Ablation> {
    let opts = req.settings.apply(WorkloadOpts::default());
    if let Some(m) = mechanisms.iter().find(|m| !changes(m, &req.hw, &opts)) {
        return Err(Error::Invalid(format!(
            "mechanism {} is already off in the reference ({}): nothing to compare",
            m.name, m.off_means
        )));
    }
    let tweaks: Vec<Option<Tweak>> =
        std::iter::once(None).chain(mechanisms.iter().map(|m| Some(m.off))).collect();
    let mut sweeps = crate::run::sweep::run_arms(req, &tweaks, library, progress)?.into_iter();
    let reference = sweeps.next().expect("the reference arm");
    Ok(Ablation { reference, arms: mechanisms.iter().copied().zip(sweeps).collect() })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper preset the ablation's reference stands for: LumiBench's workload, path end and
    /// Vulkan-Sim's child order on the SPEC hardware.
    fn paper_reference() -> (Hardware, WorkloadOpts) {
        let opts = WorkloadOpts {
            order: ChildOrder::VulkanSim,
            accel: crate::workload::Accel::TwoLevel,
            ..WorkloadOpts::default()
        };
        (Hardware::default(), opts)
    }

    #[test]
    fn every_mechanism_changes_an_input_of_the_reference() {
        let (hw, opts) = paper_reference();
        for m in MECHANISMS {
            assert!(changes(m, &hw, &opts), "{} changes nothing: its row would be the reference's", m.name);
        }
        let mut names: Vec<&str> = MECHANISMS.iter().map(|m| m.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), MECHANISMS.len(), "names are unique");
    }

    #[test]
    fn an_entry_that_changes_nothing_is_caught() {
        let (hw, opts) = paper_reference();
        let planted = Mechanism { name: "planted", what: "", off_means: "", off: |_, _| {} };
        assert!(!changes(&planted, &hw, &opts));
        // Turning off what is already off changes nothing either.
        let child_order = MECHANISMS.iter().find(|m| m.name == "child-order").unwrap();
        let nearest = WorkloadOpts { order: ChildOrder::Nearest, ..opts };
        assert!(!changes(child_order, &hw, &nearest));
        let legacy = crate::hw::preset("legacy").unwrap();
        for name in ["blocking-stack", "sh-latency", "address-map", "rt-l1d"] {
            let m = MECHANISMS.iter().find(|m| m.name == name).unwrap();
            assert!(!changes(m, &legacy, &opts), "{name} is already off in the legacy preset");
        }
    }

    #[test]
    fn the_plan_is_the_headline_set() {
        let v = plan().unwrap().variants(64).unwrap();
        let names: Vec<String> = v.iter().map(|v| v.config.name()).collect();
        assert_eq!(names[0], crate::run::sweep::BASELINE);
        assert_eq!(names.len(), 1 + HEADLINE.len());
    }
}
