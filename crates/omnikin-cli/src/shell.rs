//! `omnikin completions SHELL` and `omnikin man`: shell completion scripts (`clap_complete`)
//! and roff man pages (`clap_mangen`), both generated from the same clap definitions as
//! `--help`, so they cannot disagree with it.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::CommandFactory;

/// `omnikin completions`.
#[derive(clap::Args, Debug)]
pub struct CompletionsArgs {
    /// The shell: bash, zsh, fish, elvish or powershell. The script goes to stdout, e.g.
    /// `omnikin completions bash > ~/.local/share/bash-completion/completions/omnikin`,
    /// `omnikin completions zsh > ~/.zfunc/_omnikin`,
    /// `omnikin completions fish > ~/.config/fish/completions/omnikin.fish`.
    pub shell: clap_complete::Shell,
}

/// `omnikin man`.
#[derive(clap::Args, Debug)]
pub struct ManArgs {
    /// Write one page per command into this directory (created): omnikin.1, omnikin-plan.1,
    /// omnikin-plan-square.1, … (view with `man -l DIR/omnikin-plan.1`). Without it, the
    /// page of `omnikin` itself goes to stdout.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Prints the completion script for `a.shell`.
pub fn completions(a: &CompletionsArgs) -> Result<()> {
    let mut cmd = crate::Cli::command();
    let mut buf = Vec::new();
    clap_complete::generate(a.shell, &mut cmd, "omnikin", &mut buf);
    crate::output::Stdout
        .write_all(&buf)
        .map_err(|e| anyhow::Error::new(e).context("cannot write to stdout"))
}

/// Renders one page.
fn page(cmd: clap::Command) -> Result<Vec<u8>> {
    let mut buf = Vec::new();
    clap_mangen::Man::new(cmd).render(&mut buf)?;
    Ok(buf)
}

/// Every command with its man-page name (`omnikin-plan-square`), depth first. The names are
/// set as each command's display name, so its page is titled `omnikin-plan-square`.
fn pages(cmd: clap::Command, prefix: &str, out: &mut Vec<(String, clap::Command)>) {
    let name = if prefix.is_empty() {
        cmd.get_name().to_string()
    } else {
        format!("{prefix}-{}", cmd.get_name())
    };
    for sub in cmd.get_subcommands() {
        if sub.get_name() != "help" {
            pages(sub.clone(), &name, out);
        }
    }
    let cmd = cmd.display_name(name.clone());
    out.push((name, cmd));
}

/// Writes the man pages (or the top-level page to stdout).
pub fn man(a: &ManArgs) -> Result<()> {
    let mut cmd = crate::Cli::command();
    cmd.build();
    let Some(dir) = &a.out else {
        return crate::output::Stdout
            .write_all(&page(cmd)?)
            .map_err(|e| anyhow::Error::new(e).context("cannot write to stdout"));
    };
    let mut all = Vec::new();
    pages(cmd, "", &mut all);
    let names: Vec<String> = all.iter().map(|(n, _)| format!("{n}.1")).collect();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    crate::output::create_dir("--out", dir)?;
    for n in &refs {
        crate::output::check_file("--out", &dir.join(n))?;
    }
    for ((_, cmd), file) in all.into_iter().zip(&refs) {
        let text = page(cmd)?;
        crate::output::write_file("--out", &dir.join(file), |w| w.write_all(&text))?;
    }
    crate::errln!("wrote {} man pages to {}", refs.len(), dir.display());
    Ok(())
}
