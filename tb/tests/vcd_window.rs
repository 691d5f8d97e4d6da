//! A windowed dump of a whole-GPU run skips idle cycles outside its window and still shows, in
//! the window, exactly the values a dump of every cycle shows.

use tb::run::sim::{simulate, Fidelity, Hardware, Outcome, RunSpec};
use tb::vcd::check::{read, Mode, Waves};
use tb::vcd::{Selection, VcdSink};
use tb::workload::{Workload, WorkloadOpts};

fn dump(w: &Workload, spec: &RunSpec, select: Selection) -> (Waves, Outcome) {
    let mut sink = VcdSink::new(Vec::new(), select, &spec.config).unwrap();
    let o = simulate(spec, w, None, &mut sink, |_| {}).unwrap();
    let text = sink.finish().unwrap();
    (read(&text[..], Mode::Strict).unwrap_or_else(|e| panic!("{e}")), o)
}

#[test]
fn window_values_equal_the_full_dump_and_idle_cycles_outside_are_skipped() {
    let Some(scene) = tb::prereq::scene("ship") else { return };
    let w = Workload::new(&scene, WorkloadOpts::quick(&scene, 16)).unwrap();
    let spec = RunSpec { config: "SMS".parse().unwrap(), hw: Hardware::default(), fidelity: Fidelity::Cycle };
    let sm0 = Selection { sms: Some(vec![0]), lanes: Some(vec![0, 1, 2, 3]), ..Selection::default() };
    let (full, fo) = dump(&w, &spec, sm0.clone());
    let cycles = fo.gpu.unwrap().cycles;
    let (from, to) = (cycles / 2, cycles / 2 + 2_000);
    let (part, po) = dump(&w, &spec, Selection { from: Some(from), to: Some(to), ..sm0 });

    assert_eq!(fo.stack, po.stack, "dumping does not change the run");
    assert_eq!(cycles, po.gpu.unwrap().cycles);
    let (fe, pe) = (fo.gpu.unwrap().evaluated_cycles, po.gpu.unwrap().evaluated_cycles);
    assert_eq!(fe, cycles, "a dump of every cycle evaluates every cycle");
    assert!(pe < fe, "outside the window idle cycles are skipped ({pe} of {fe} evaluated)");

    assert_eq!(full.signals, part.signals);
    let outside: Vec<u64> = part.times().filter(|t| !(from..=to + 1).contains(t)).collect();
    assert!(outside.is_empty(), "written outside the window [{from},{to}] (+ end mark): {outside:?}");
    let (mut a, mut b) = (full.replay(), part.replay());
    let mut compared = 0;
    for c in from..=to {
        let (x, y) = (a.at(c).unwrap().to_vec(), b.at(c).unwrap());
        assert_eq!(x, y, "cycle {c}");
        compared += x.len();
    }
    assert!(compared > 100_000, "{compared} values compared");
}
