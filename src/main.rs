//! `nurbs-contact`: run or check a case file, or run a study. CLI only: parse, initialise MPI and PETSc, hand over to
//! [`nurbs_contact::driver`], report.

use clap::{CommandFactory, Parser, Subcommand};
use nurbs_contact::driver::{self, RunOptions, Verbosity};
use std::path::PathBuf;
use std::process::ExitCode;

/// Large-deformation contact with NURBS-enriched contact elements (Corbett & Sauer 2014).
///
/// Any PETSc option (single dash and a name, e.g. `-snes_monitor`, `-ksp_view`, `-log_view`,
/// `-pc_factor_mat_solver_type superlu_dist`) may be given anywhere on the command line and reaches
/// PETSc's options database unchanged; it overrides the case's `solver.petsc_options`.
/// Run in parallel with `mpirun -np N nurbs-contact run CASE.toml`.
#[derive(Parser, Debug)]
#[command(name = "nurbs-contact", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Solve a case and write results.h5 + results.xdmf, history.csv and summary.json.
    Run {
        /// The case file (TOML).
        case: PathBuf,
        /// Output directory (default: out/<case name>/).
        #[arg(long, short = 'o')]
        out: Option<PathBuf>,
        /// Override a case value, e.g. `--set meshes.block.divisions=[20,20,20]` or
        /// `--set stages.0.steps=10`; may be repeated.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        sets: Vec<String>,
        /// More log output (repeat for more).
        #[arg(short, long, action = clap::ArgAction::Count)]
        verbose: u8,
        /// Only errors.
        #[arg(short, long)]
        quiet: bool,
        /// Assemble the Jacobian with MatSetValues on an exactly preallocated matrix instead of the
        /// COO interface (for benchmarks).
        #[arg(long)]
        matsetvalues: bool,
        /// Write into the output directory even if it exists and holds files that are not from an
        /// earlier nurbs-contact run (files of the same names are replaced, others are kept).
        #[arg(long)]
        overwrite: bool,
        /// Write a checkpoint (DIR/checkpoints/step-N/) after every N converged load steps, and
        /// when a signal stops the run; only the newest is kept.
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
        checkpoint_every: Option<u64>,
        /// Continue the run in DIR from its last checkpoint (results go on in DIR unless --out):
        /// refused if the case differs in anything but `output` and stages not yet started.
        #[arg(long, value_name = "DIR")]
        restart: Option<PathBuf>,
    },
    /// Validate a case (schema, references, meshes, sets, boundary conditions) without solving.
    Check {
        /// The case file (TOML).
        case: PathBuf,
        /// Overrides, as for `run`.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        sets: Vec<String>,
    },
    /// Run a refinement study: a case over every combination of a study file's axes, with metrics,
    /// `study.csv`, `study.md` and SVG plots (file format: docs/user-guide/studies.md).
    Study {
        /// The study file (TOML).
        study: PathBuf,
        /// Output folder (default: out/study/<study name>/).
        #[arg(long, short = 'o')]
        out: Option<PathBuf>,
        /// Only validate the study file and `check` every run's case, without running.
        #[arg(long)]
        check: bool,
        /// Runs executed at once (overrides the file's `jobs`).
        #[arg(long, short = 'j')]
        jobs: Option<usize>,
        /// Only errors and failed runs.
        #[arg(short, long)]
        quiet: bool,
        /// Where the runs execute: `local` (subprocesses, `jobs` at a time) or `slurm` (writes
        /// OUT/study.sbatch, a job array with one task per run, and submits it with sbatch).
        #[arg(long, value_enum, default_value_t = LauncherArg::Local)]
        launcher: LauncherArg,
        /// With --launcher slurm: write the job script but do not submit it.
        #[arg(long)]
        dry_run: bool,
        /// Build study.csv, study.md and plots from the runs that have finished (e.g. under Slurm),
        /// naming those that failed or have no result yet; runs nothing.
        #[arg(long, conflicts_with_all = ["check", "dry_run"])]
        collect: bool,
    },
    /// Write the generated reference pages: the case file's JSON Schema (case-schema.json), its
    /// keys (case-keys.md) and this command line (cli.md).
    Reference {
        /// Output directory (created if missing).
        #[arg(long, short = 'o', value_name = "DIR", default_value = nurbs_contact::reference::DEFAULT_DIR)]
        out: PathBuf,
    },
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum LauncherArg {
    Local,
    Slurm,
}

/// Splits the command line into our arguments and PETSc's: a PETSc option is a single dash followed by
/// a name of two or more characters (`-snes_rtol`), plus its value when the next word is not itself an
/// option (numbers like `-1e-8` count as values).
fn split_petsc_args(args: Vec<String>) -> (Vec<String>, Vec<String>) {
    let is_petsc_opt = |a: &str| {
        a.starts_with('-')
            && !a.starts_with("--")
            && a.len() > 2
            && a[1..].starts_with(|c: char| c.is_ascii_alphabetic())
            && !a[1..].chars().all(|c| c == 'v' || c == 'q')
    };
    let mut ours = Vec::new();
    let mut petsc = Vec::new();
    let mut it = args.into_iter().peekable();
    if let Some(prog) = it.next() {
        ours.push(prog.clone());
        petsc.push(prog);
    }
    while let Some(a) = it.next() {
        if is_petsc_opt(&a) {
            petsc.push(a);
            if let Some(next) = it.peek() {
                if !next.starts_with('-') || next.parse::<f64>().is_ok() {
                    petsc.push(it.next().unwrap_or_default());
                }
            }
        } else {
            ours.push(a);
        }
    }
    (ours, petsc)
}

fn main() -> ExitCode {
    let (ours, petsc_args) = split_petsc_args(std::env::args().collect());
    let cli = Cli::parse_from(ours);
    let result = match cli.command {
        Command::Run {
            case,
            out,
            sets,
            verbose,
            quiet,
            matsetvalues,
            overwrite,
            checkpoint_every,
            restart,
        } => driver::run_main(RunOptions {
            case,
            out,
            sets,
            petsc_args,
            verbosity: if quiet {
                Verbosity::Quiet
            } else {
                Verbosity::from_count(verbose)
            },
            matsetvalues,
            overwrite,
            checkpoint_every: checkpoint_every.map(|n| n as usize),
            restart,
        }),
        Command::Check { case, sets } => driver::check_main(&case, &sets, petsc_args),
        Command::Reference { out } => {
            return match nurbs_contact::reference::write_pages(&out, &Cli::command()) {
                Ok(paths) => {
                    for p in paths {
                        println!("wrote {}", p.display());
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::FAILURE
                }
            };
        }
        Command::Study {
            study,
            out,
            check,
            jobs,
            quiet,
            launcher,
            dry_run,
            collect,
        } => {
            use nurbs_contact::study::Launcher;
            let opts = nurbs_contact::study::StudyOptions {
                file: study,
                out,
                check,
                jobs,
                quiet,
                petsc_args,
                launcher: match launcher {
                    LauncherArg::Local => Launcher::Local,
                    LauncherArg::Slurm => Launcher::Slurm,
                },
                dry_run,
                collect,
            };
            return match nurbs_contact::study::study_main(&opts) {
                Ok(()) => ExitCode::SUCCESS,
                Err(e @ nurbs_contact::study::StudyError::Interrupted { signal, .. }) => {
                    eprintln!("error: {e}");
                    ExitCode::from(nurbs_contact::interrupt::exit_code(signal))
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::FAILURE
                }
            };
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // `run` has already printed the error on rank 0 while all ranks were still alive.
        Err(driver::Error::OtherRank | driver::Error::Reported) => ExitCode::FAILURE,
        // Printed too; the conventional code of the signal (130 for SIGINT, 143 for SIGTERM).
        Err(driver::Error::Interrupted { signal, .. }) => {
            ExitCode::from(nurbs_contact::interrupt::exit_code(signal))
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::split_petsc_args;

    fn s(v: &[&str]) -> Vec<String> {
        v.iter().map(|x| x.to_string()).collect()
    }

    #[test]
    fn petsc_options_are_split_from_ours_with_their_values() {
        let (ours, petsc) = split_petsc_args(s(&[
            "nc",
            "run",
            "c.toml",
            "-snes_monitor",
            "--out",
            "d",
            "-snes_rtol",
            "1e-12",
            "-v",
            "-vv",
            "-mat_shift",
            "-1e-3",
            "--set",
            "a.b=1",
        ]));
        assert_eq!(
            ours,
            s(&["nc", "run", "c.toml", "--out", "d", "-v", "-vv", "--set", "a.b=1"])
        );
        assert_eq!(
            petsc,
            s(&[
                "nc",
                "-snes_monitor",
                "-snes_rtol",
                "1e-12",
                "-mat_shift",
                "-1e-3"
            ])
        );
    }
}
