//! `sms bench`'s reports: the verdict, the terminal and Markdown text, and the files
//! (text, Markdown, CSV, JSON and the plot).

use std::path::Path;

use super::tables::pct;
use crate::error::{Error, Result};
use crate::report::table::Table;
use crate::run::bench::data::{fastest_within, worse, Headline, Report, Setting};
use crate::run::sim::Fidelity;

impl Report {
    /// The verdict lines: the fastest setting within `tolerance` on every headline metric, then on
    /// each alone.
    pub fn verdict(&self, tolerance: f64) -> String {
        let full: f64 = self.rows.iter().filter(|r| r.setting == Setting::FULL_CYCLE).map(|r| r.wall).sum();
        let line = |which: &[Headline], what: String| {
            match fastest_within(&self.rows, tolerance, which) {
            Some(c) => format!(
                "fastest within {}% on {what}: {} ({:.3} s against {:.3} s for the full cycle level, {:.1}x faster; worst error {:.2}%)\n",
                tolerance * 100.0,
                c.setting,
                c.wall,
                full,
                full / c.wall,
                c.worst * 100.0
            ),
            None => format!("no setting is within {}% on {what}\n", tolerance * 100.0),
        }
        };
        let mut out = line(&Headline::ALL, "every headline metric (all scenes and configurations)".into());
        for h in Headline::ALL {
            out += &line(&[h], format!("{} alone", h.name()));
        }
        // Reallocation makes the functional level's counts differ from the cycle level's.
        let functional = Setting { fidelity: Fidelity::Functional, sample: None };
        let ra = self.rows.iter().filter(|r| r.setting == functional && r.config.ends_with("+RA"));
        let worst = ra.map(|r| r.errors.stack_global.unwrap_or(f64::NAN)).reduce(worse);
        if let Some(e) = worst {
            out += &format!(
                "functional level with reallocation (all warps): off-chip stack error {} at worst\n",
                pct(Some(e))
            );
        }
        out
    }

    /// The terminal and Markdown reports.
    pub fn text(&self, tolerance: f64, markdown: bool) -> String {
        let render = |t: Table| if markdown { t.to_markdown() } else { t.to_text() };
        let heading = |s: &str| if markdown { format!("\n## {s}\n\n") } else { format!("\n{s}\n") };
        let mut out = String::new();
        out += &heading("Workloads");
        for info in &self.scenes {
            out += &format!("{}{info}\n", if markdown { "- " } else { "" });
        }
        out += &heading("Run time against error (errors relative to the full cycle-level run)");
        out += "err = |value − full cycle-level value| / full cycle-level value, on workload totals \
                (sampled: estimates); perf = RB_8's cycles / the configuration's, both from the same \
                setting; n/a = not measured at that level; ±95% = widest relative 95 % interval of the \
                sampled estimates; time includes tracing the rays, not building the BVH.\n";
        if markdown {
            out += "\n";
        }
        out += &render(self.rows_table());
        out += &heading("Per setting, over every scene and configuration");
        out += &render(self.summary_table(tolerance));
        out += "\n";
        out += &self.verdict(tolerance);
        out += &heading("Throughput of the full cycle-level model");
        out += &render(self.throughput_table());
        out += &heading("Work by kind and stack depth");
        out += &render(self.work_table());
        out += &heading("Savings of skipping work a run does not need");
        out += &render(self.savings_table());
        out += &heading("Memory");
        out += &format!(
            "peak resident memory of this bench (every scene and setting): {}\n",
            crate::run::memory::describe(self.peak_rss)
        );
        out
    }

    /// `bench.md`: the Markdown report under its title.
    pub fn markdown(&self, tolerance: f64) -> String {
        format!("# sms bench\n{}", self.text(tolerance, true))
    }

    /// `bench.json`: `{ tolerance, fastest, report }` (layout: docs/json.md).
    pub fn json(&self, tolerance: f64) -> Result<String> {
        let json = serde_json::json!({
            "tolerance": tolerance,
            "fastest": fastest_within(&self.rows, tolerance, &Headline::ALL),
            "report": self,
        });
        serde_json::to_string_pretty(&json).map_err(|e| Error::Invalid(e.to_string()))
    }

    /// Writes bench.{txt,md,csv,json}, the other tables as CSV and the plot into `dir`.
    pub fn write(&self, dir: &Path, tolerance: f64) -> Result<()> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let write = |name: &str, text: String| {
            let path = dir.join(name);
            std::fs::write(&path, text).map_err(|e| Error::io(&path, e))
        };
        write("bench.txt", self.text(tolerance, false))?;
        write("bench.md", self.markdown(tolerance))?;
        write("bench.csv", self.rows_table().to_csv())?;
        write("summary.csv", self.summary_table(tolerance).to_csv())?;
        write("throughput.csv", self.throughput_table().to_csv())?;
        write("work.csv", self.work_table().to_csv())?;
        write("savings.csv", self.savings_table().to_csv())?;
        write("bench.json", self.json(tolerance)?)?;
        self.write_svg(&dir.join("time-vs-error.svg"))
    }
}
