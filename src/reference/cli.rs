//! `cli.md`: the command line, rendered from the binary's clap command: for the program and each
//! subcommand its long description, usage line, arguments and options (with their value names,
//! defaults and possible values).

use std::fmt::Write;

/// The whole page for `cmd` (the binary's top-level command).
pub fn render(cmd: &clap::Command) -> String {
    let mut cmd = cmd.clone();
    cmd.build();
    let name = cmd.get_name().to_string();
    let mut out = format!(
        "# Command-line reference\n\n\
         Generated from the command-line parser by `{name} reference --out docs/reference`; do not \
         edit by hand. `{name} help <command>` prints the same text.\n\n"
    );
    command(&mut out, &mut cmd, &name, 2);
    out
}

/// The section of `cmd` (full name `path`) at heading `level`, then its subcommands'.
fn command(out: &mut String, cmd: &mut clap::Command, path: &str, level: usize) {
    let _ = writeln!(out, "{} `{path}`\n", "#".repeat(level));
    let about = cmd
        .get_long_about()
        .or(cmd.get_about())
        .map(|a| a.to_string())
        .unwrap_or_default();
    if !about.is_empty() {
        let _ = writeln!(out, "{}\n", super::escape_prose(about.trim_end()));
    }
    let usage = cmd.render_usage().to_string();
    let usage = usage.trim().trim_start_matches("Usage:").trim();
    let _ = writeln!(out, "```text\n{usage}\n```\n");

    let args: Vec<&clap::Arg> = cmd.get_arguments().filter(|a| !a.is_hide_set()).collect();
    let (positional, options): (Vec<&clap::Arg>, Vec<&clap::Arg>) =
        args.into_iter().partition(|a| a.is_positional());
    if !positional.is_empty() {
        let _ = writeln!(out, "Arguments:\n");
        for a in positional {
            argument(out, a);
        }
        out.push('\n');
    }
    if !options.is_empty() {
        let _ = writeln!(out, "Options:\n");
        for a in options {
            argument(out, a);
        }
        out.push('\n');
    }
    let subs: Vec<String> = cmd
        .get_subcommands()
        .filter(|s| !s.is_hide_set())
        .map(|s| s.get_name().to_string())
        .collect();
    if !subs.is_empty() {
        let _ = writeln!(out, "Commands:\n");
        for s in &subs {
            let sub = cmd.find_subcommand(s).expect("listed subcommand");
            let about = sub.get_about().map(|a| a.to_string()).unwrap_or_default();
            let _ = writeln!(out, "- `{s}`: {}", sentence(&about));
        }
        out.push('\n');
    }
    for s in subs {
        if s == "help" {
            continue;
        }
        let sub = cmd.find_subcommand_mut(&s).expect("listed subcommand");
        command(out, sub, &format!("{path} {s}"), level + 1);
    }
}

/// One list item: `` `-o`, `--out <OUT>` ``, what it does, its default and possible values.
fn argument(out: &mut String, a: &clap::Arg) {
    let value = match a.get_value_names() {
        Some(names) if a.get_num_args().is_none_or(|n| n.takes_values()) => names
            .iter()
            .map(|n| format!("<{n}>"))
            .collect::<Vec<_>>()
            .join(" "),
        _ => String::new(),
    };
    let takes_value = a.get_action().takes_values();
    let value = if takes_value && value.is_empty() {
        format!("<{}>", a.get_id().as_str())
    } else {
        value
    };
    let mut names = Vec::new();
    if a.is_positional() {
        names.push(value.clone());
    } else {
        if let Some(s) = a.get_short() {
            names.push(format!("-{s}"));
        }
        if let Some(l) = a.get_long() {
            let long = if takes_value {
                format!("--{l} {value}")
            } else {
                format!("--{l}")
            };
            names.push(long);
        }
    }
    let names: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
    let help = a
        .get_long_help()
        .or(a.get_help())
        .map(|h| h.to_string())
        .unwrap_or_default();
    let help = sentence(&help);
    let _ = write!(out, "- {}", names.join(", "));
    if a.is_required_set() {
        out.push_str(" (required)");
    }
    if !help.is_empty() {
        let _ = write!(out, ": {help}");
    }
    let possible: Vec<String> = a
        .get_possible_values()
        .iter()
        .filter(|p| !p.is_hide_set())
        .map(|p| format!("`{}`", p.get_name()))
        .collect();
    if takes_value && !possible.is_empty() {
        let _ = write!(out, " Possible values: {}.", possible.join(", "));
    }
    // a flag's implicit default (`false`, a count of 0) says nothing
    let defaults: Vec<String> = a
        .get_default_values()
        .iter()
        .map(|d| format!("`{}`", d.to_string_lossy()))
        .collect();
    if takes_value && !defaults.is_empty() {
        let _ = write!(out, " Default: {}.", defaults.join(", "));
    }
    out.push('\n');
}

/// Help text on one line, escaped, ending in a full stop (clap drops the doc comment's).
fn sentence(text: &str) -> String {
    let mut s = text.split_whitespace().collect::<Vec<_>>().join(" ");
    if !s.is_empty() && !s.ends_with(['.', '!', '?', ')']) {
        s.push('.');
    }
    super::escape_prose(&s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::{Arg, ArgAction, Command};

    #[test]
    fn commands_arguments_options_defaults_and_values_are_listed() {
        let cmd = Command::new("tool").long_about("Does things.").subcommand(
            Command::new("go")
                .about("Go somewhere.")
                .arg(Arg::new("file").required(true).help("The file."))
                .arg(
                    Arg::new("out")
                        .long("out")
                        .short('o')
                        .value_name("DIR")
                        .help("Where."),
                )
                .arg(
                    Arg::new("mode")
                        .long("mode")
                        .value_parser(["fast", "slow"])
                        .default_value("fast")
                        .help("How."),
                )
                .arg(
                    Arg::new("quiet")
                        .long("quiet")
                        .action(ArgAction::SetTrue)
                        .help("Hush."),
                ),
        );
        let page = render(&cmd);
        for line in [
            "## `tool`\n\nDoes things.\n",
            "- `go`: Go somewhere.",
            "### `tool go`",
            "- `<file>` (required): The file.",
            "- `-o`, `--out <DIR>`: Where.",
            "- `--mode <mode>`: How. Possible values: `fast`, `slow`. Default: `fast`.",
            "- `--quiet`: Hush.\n",
            "- `-h`, `--help`: Print help.",
        ] {
            assert!(page.contains(line), "missing {line:?} in\n{page}");
        }
        assert!(!page.contains("`tool help`"), "{page}");
    }
}
