//! SMT solvers as processes speaking SMT-LIB 2 on stdin (Debian's `z3`, `boolector` and
//! `cvc5`): a query is
//! satisfiable (a counterexample, with the values of the variables asked for), unsatisfiable
//! (proved), or unknown within the time limit.

use std::io::Write;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};

/// A solver the proofs run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Solver {
    Z3,
    Boolector,
    Cvc5,
}

impl Solver {
    pub const ALL: [Solver; 3] = [Solver::Z3, Solver::Boolector, Solver::Cvc5];

    pub fn name(self) -> &'static str {
        match self {
            Solver::Z3 => "z3",
            Solver::Boolector => "boolector",
            Solver::Cvc5 => "cvc5",
        }
    }

    pub fn from_name(s: &str) -> Option<Solver> {
        Solver::ALL.into_iter().find(|x| x.name() == s)
    }

    fn command(self, limit: Duration) -> Command {
        let ms = limit.as_millis().max(1);
        let mut c = Command::new(self.name());
        match self {
            Solver::Z3 => c.args(["-in", "-smt2", &format!("-t:{ms}")]),
            // Boolector prints the model itself (`-m`; it has no `get-value`), in its own
            // format: a line per variable, `name bits`.
            Solver::Boolector => c.args(["--smt2", "-m", "-t", &limit.as_secs().max(1).to_string()]),
            Solver::Cvc5 => c.args(["--lang", "smt2", "--produce-models", &format!("--tlimit-per={ms}")]),
        };
        c
    }

    /// Fails with what to install when the solver is not on the PATH.
    /// The two solvers every proof runs by default (z3, boolector), each checked installed:
    /// an error names the Debian package of the first missing one.
    pub fn defaults_installed() -> Result<Vec<Solver>> {
        let s = vec![Solver::Z3, Solver::Boolector];
        for x in &s {
            x.check_installed()?;
        }
        Ok(s)
    }

    pub fn check_installed(self) -> Result<()> {
        match Command::new(self.name())
            .arg("--version")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
        {
            Ok(_) => Ok(()),
            Err(_) => bail!(
                "{} not found: install Debian's `{}` package (apt-get install {})",
                self.name(),
                self.name(),
                self.name()
            ),
        }
    }
}

/// What a solver said about one query.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Unsatisfiable: no state violates the property.
    Proved,
    /// Satisfiable: the variables' values in a violating state, as the solver printed them.
    Counterexample(Vec<(String, u64)>),
    /// The solver gave up or ran out of time.
    Unknown(String),
}

/// Runs `solver` on `query` (SMT-LIB 2 with its assertions); on `sat`, asks for the values of
/// `vars`. Returns the verdict and the wall time.
pub fn check(solver: Solver, query: &str, vars: &[String], limit: Duration) -> Result<(Verdict, Duration)> {
    let start = Instant::now();
    let mut text = String::with_capacity(query.len() + 64 * vars.len());
    if solver == Solver::Boolector {
        // It stops at a command it does not know: no options, no `get-value`.
        text.extend(query.lines().filter(|l| !l.starts_with("(set-option")).flat_map(|l| [l, "\n"]));
        text.push_str("(check-sat)\n(exit)\n");
    } else {
        text.push_str(query);
        text.push_str("(check-sat)\n");
        if !vars.is_empty() {
            text.push_str("(get-value (");
            for v in vars {
                text.push_str(v);
                text.push(' ');
            }
            text.push_str("))\n");
        }
        text.push_str("(exit)\n");
    }
    let mut child = solver
        .command(limit)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .with_context(|| {
            format!("starting {} (install Debian's `{}` package)", solver.name(), solver.name())
        })?;
    let mut stdin = child.stdin.take().expect("piped stdin");
    let writer = std::thread::spawn(move || stdin.write_all(text.as_bytes()));
    let out = child.wait_with_output()?;
    // A solver that stops reading (a timeout) closes the pipe: not an error of ours.
    let _ = writer.join();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let first = stdout.lines().next().unwrap_or("").trim();
    let verdict = match first {
        "unsat" => Verdict::Proved,
        "sat" if solver == Solver::Boolector => Verdict::Counterexample(parse_model_lines(&stdout, vars)),
        "sat" => Verdict::Counterexample(parse_values(&stdout)),
        "unknown" | "timeout" => Verdict::Unknown(format!("{} said {first}", solver.name())),
        _ => {
            let err = String::from_utf8_lossy(&out.stderr);
            let why = stdout.lines().chain(err.lines()).find(|l| !l.trim().is_empty()).unwrap_or("no output");
            Verdict::Unknown(format!("{}: {}", solver.name(), why.trim()))
        }
    };
    Ok((verdict, start.elapsed()))
}

/// `((name value) ...)` pairs of a `get-value` answer: `true`/`false`, `#x…`, `#b…` or
/// `(_ bvN W)`.
fn parse_values(out: &str) -> Vec<(String, u64)> {
    let body: String = out.lines().skip(1).collect::<Vec<_>>().join(" ");
    let tokens: Vec<String> =
        body.replace('(', " ( ").replace(')', " ) ").split_whitespace().map(str::to_string).collect();
    let mut vals = Vec::new();
    let mut i = 0;
    while i + 1 < tokens.len() {
        if tokens[i] == "(" && tokens[i + 1] != "(" && tokens[i + 1] != "_" && i + 2 < tokens.len() {
            let name = tokens[i + 1].clone();
            let v = &tokens[i + 2];
            let parsed = if v == "true" {
                Some(1)
            } else if v == "false" {
                Some(0)
            } else if let Some(h) = v.strip_prefix("#x") {
                u64::from_str_radix(h, 16).ok()
            } else if let Some(b) = v.strip_prefix("#b") {
                u64::from_str_radix(b, 2).ok()
            } else if v == "(" && tokens.get(i + 3).map(String::as_str) == Some("_") {
                tokens.get(i + 4).and_then(|t| t.strip_prefix("bv")).and_then(|d| d.parse().ok())
            } else {
                None
            };
            if let Some(x) = parsed {
                vals.push((name, x));
            }
        }
        i += 1;
    }
    vals
}

/// Boolector's model: a line per variable, `name bits` (bits in binary; a Bool is one bit).
fn parse_model_lines(out: &str, vars: &[String]) -> Vec<(String, u64)> {
    out.lines()
        .skip(1)
        .filter_map(|l| {
            let (name, bits) = l.trim().split_once(' ')?;
            let v = u64::from_str_radix(bits.get(bits.len().saturating_sub(64)..)?, 2).ok()?;
            vars.iter().any(|x| x == name).then(|| (name.to_string(), v))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_in_every_solver_format_are_read() {
        let out = "sat\n((a #x0000000a) (b true)\n (c #b101) (d (_ bv7 32)))\n";
        let v = parse_values(out);
        assert_eq!(v, vec![("a".into(), 10), ("b".into(), 1), ("c".into(), 5), ("d".into(), 7)],);
    }
}
