//! The figures of the station over Modbus TCP: N parts through the wire (the simulated PLC on
//! 127.0.0.1, the in-process camera stand-in at the twin's fast fidelity) against the same seed
//! on the in-process twin; pushes, final e, time per phase (mean ± standard error), link round
//! trip p50/p99, frames paired with angles.
//!
//! `cargo run --release -p gonio-plc --example wire_figures -- PARTS SEED STRATEGY`
//! (STRATEGY: live, learned, paper, least-squares).

use gonio_plc::batch::{PartEnd, run_batch};
use gonio_plc::link::Link;
use gonio_plc::map::RegisterMap;
use gonio_plc::sim::{SimConfig, SimServer, SimTriggered};
use gonio_plc::station::{PlcStation, StationOptions};
use gonio_sim::station::{BatchConfig, run_batch as twin_batch};
use gonio_station::{Controller, Recipe, Strategy};

fn mean_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, (var / n).sqrt())
}

fn row(name: &str, wire: &[f64], twin: &[f64]) {
    let (a, sa) = mean_se(wire);
    let (b, sb) = mean_se(twin);
    let z = (a - b) / (sa * sa + sb * sb).sqrt().max(1e-12);
    println!("| {name} | {a:.2} ± {sa:.2} | {b:.2} ± {sb:.2} | {z:+.1} |");
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let parts: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(25);
    let seed: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let strategy = match args.get(3).map(String::as_str).unwrap_or("live") {
        "learned" => Strategy::Learned,
        "paper" => Strategy::Paper,
        "least-squares" => Strategy::LeastSquares,
        _ => Strategy::Live,
    };
    let recipe = Recipe::default();

    let mut server = SimServer::start(SimConfig::new(seed), "127.0.0.1:0".parse().unwrap())
        .expect("the simulated PLC starts");
    let camera = SimTriggered::new(server.take_frames().expect("frames"));
    let link = Link::connect(&server.addr().to_string(), RegisterMap::default()).expect("link");
    let opts = StationOptions {
        fps: recipe.measure.fps,
        exposure_s: recipe.measure.exposure_s,
        um_per_px: recipe.um_per_px,
    };
    let station = PlcStation::new(link, camera, opts).expect("station");
    let mut ctl = Controller::new(recipe.clone(), strategy);
    let t0 = std::time::Instant::now();
    let report = run_batch(&station, &mut ctl, parts, &mut |d| {
        eprintln!(
            "part {} {} e {:?} µm, {} pushes, {:?} s",
            d.part,
            d.record.result.name(),
            d.record.final_e_um,
            d.record.pushes,
            d.record.time_s
        );
        PartEnd::Continue
    })
    .expect("batch");
    let wall = t0.elapsed().as_secs_f64();
    let truth = server.truth();
    server.stop();

    let cfg = BatchConfig {
        parts,
        strategy,
        recipe,
        ..BatchConfig::default()
    };
    let twin = twin_batch(&cfg, seed, &mut |_, _, _| {}).expect("twin batch");

    let w = &report.parts;
    let t = &twin.parts;
    // The values a figure has on each part (undefined ones, e.g. a rejected part's final e, left out).
    let f = |v: &dyn Fn(&gonio_station::PartRecord) -> Option<f64>,
             w: &[gonio_plc::batch::PlcPart]| {
        w.iter().filter_map(|p| v(&p.record)).collect::<Vec<f64>>()
    };
    let g = |v: &dyn Fn(&gonio_station::PartRecord) -> Option<f64>| {
        t.iter().filter_map(|p| v(&p.record)).collect::<Vec<f64>>()
    };
    let true_final: Vec<f64> = w
        .iter()
        .filter_map(|p| truth.iter().find(|x| x.part == p.part))
        .map(|x| x.true_final_e_um)
        .collect();
    let err: Vec<f64> = w
        .iter()
        .filter_map(|p| {
            truth
                .iter()
                .find(|x| x.part == p.part)
                .zip(p.record.final_e_um)
                .map(|(x, e)| (e - x.true_final_e_um).abs())
        })
        .collect();
    println!(
        "strategy {}, seed {seed}, {} parts through the wire ({} accepted) in {wall:.0} s; twin: {} accepted",
        strategy.name(),
        w.len(),
        w.iter()
            .filter(|p| p.record.result == gonio_station::PartResult::Accepted)
            .count(),
        t.iter()
            .filter(|p| p.record.result == gonio_station::PartResult::Accepted)
            .count()
    );
    println!("| figure | through the wire | twin in process | z |");
    println!("| --- | --- | --- | --- |");
    row(
        "pushes",
        &f(&|r| Some(r.pushes as f64), w),
        &g(&|r| Some(r.pushes as f64)),
    );
    row(
        "final e / µm (measured)",
        &f(&|r| r.final_e_um, w),
        &g(&|r| r.final_e_um),
    );
    row(
        "true final e / µm",
        &true_final,
        &t.iter().map(|p| p.true_final_e_um).collect::<Vec<_>>(),
    );
    row(
        "|measured − true| final e / µm",
        &err,
        &t.iter()
            .filter_map(|p| p.record.final_e_um.map(|e| (e - p.true_final_e_um).abs()))
            .collect::<Vec<_>>(),
    );
    row("time / s", &f(&|r| r.time_s, w), &g(&|r| r.time_s));
    row(
        "focus / s",
        &f(&|r| Some(r.phase_times.focus_s), w),
        &g(&|r| Some(r.phase_times.focus_s)),
    );
    row(
        "measure / s",
        &f(&|r| Some(r.phase_times.measure_s), w),
        &g(&|r| Some(r.phase_times.measure_s)),
    );
    row(
        "push / s",
        &f(&|r| Some(r.phase_times.push_s), w),
        &g(&|r| Some(r.phase_times.push_s)),
    );
    let l = &report.link;
    let ms = |x: Option<f64>| x.map_or("–".to_string(), |v| format!("{v:.3}"));
    println!(
        "link: {} requests, round trip p50 {} ms, p99 {} ms; frames paired {}, stale skipped {}",
        l.requests,
        ms(l.round_trip_p50_ms),
        ms(l.round_trip_p99_ms),
        l.frames_paired,
        l.frames_stale
    );
}
