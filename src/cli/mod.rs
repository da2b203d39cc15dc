//! The command line: a thin layer that parses flags and calls the library.

pub mod args;
pub mod bench;
pub mod render;
pub mod view;

use std::collections::HashSet;

use clap::parser::ValueSource;
use clap::{ArgMatches, CommandFactory, FromArgMatches, Parser, Subcommand};

use args::RenderArgs;
use view::ViewArgs;

/// meshtracer: a Vulkan compute-shader ray tracer for triangle meshes, after Kim & Shin's
/// "Mesh-based ray tracing system using Vulkan". With no command it opens the interactive
/// tool on the paper's scene: a model inside six mirror planes, lit by an orbiting light.
#[derive(Parser, Debug)]
#[command(name = "meshtracer", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    #[command(flatten)]
    pub view: ViewArgs,
}

/// What to do.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Open the interactive tool (the default).
    View(ViewArgs),
    /// Render one frame headless and write it to a file.
    Render(RenderArgs),
    /// Measure frame times: the paper's tables (--paper) and scaling series (--scaling).
    Bench(bench::BenchArgs),
    /// List the Vulkan devices (for --device).
    Devices,
}

impl Cli {
    /// Parse the process's command line like [`Parser::try_parse`], noting which flags
    /// were given on it (they override a `--preset`; the others do not).
    pub fn try_parse_noting_flags() -> Result<Self, clap::Error> {
        Self::try_parse_from_noting_flags(std::env::args_os())
    }

    /// [`Cli::try_parse_noting_flags`] over `args` (the program name first).
    pub fn try_parse_from_noting_flags<I, T>(args: I) -> Result<Self, clap::Error>
    where
        I: IntoIterator<Item = T>,
        T: Into<std::ffi::OsString> + Clone,
    {
        let matches = Self::command().try_get_matches_from(args)?;
        let mut cli = Self::from_arg_matches(&matches)?;
        let sub = matches.subcommand().map(|(_, m)| given_flags(m));
        match &mut cli.command {
            Some(Command::Render(args)) => args.scene.given = sub,
            Some(Command::View(args)) => args.scene.given = sub,
            Some(Command::Bench(args)) => args.given = sub,
            Some(Command::Devices) => {}
            None => cli.view.scene.given = Some(given_flags(&matches)),
        }
        Ok(cli)
    }
}

/// The ids of the arguments given on the command line (not defaults).
fn given_flags(matches: &ArgMatches) -> HashSet<String> {
    matches
        .ids()
        .filter(|id| matches.value_source(id.as_str()) == Some(ValueSource::CommandLine))
        .map(|id| id.to_string())
        .collect()
}

/// `meshtracer devices`: print the Vulkan devices with their indices.
pub fn devices() -> anyhow::Result<()> {
    for (i, name) in crate::gpu::context::list_devices()?.iter().enumerate() {
        println!("{i}: {name}");
    }
    Ok(())
}

/// The logger's filter when `RUST_LOG` sets none: every warning, but the clipboard crate's
/// and winit's X11 backend's only from errors up. Without a clipboard manager (a bare X
/// session, Xvfb) the clipboard warned at every exit after "Copy as flags" that it could not
/// hand the text over, and winit at every start about XSETTINGS and a 0 mm display: lines
/// the user can do nothing about (issue #43).
pub const LOG_FILTER: &str = "warn,arboard=error,winit::platform_impl::linux::x11=error";

#[cfg(test)]
mod tests {
    #[test]
    fn the_clipboards_handover_warning_is_not_printed_and_ours_are() {
        use log::Log;
        let logger = env_logger::Builder::new().parse_filters(super::LOG_FILTER).build();
        let warning =
            |target| log::Metadata::builder().level(log::Level::Warn).target(target).build();
        assert!(!logger.enabled(&warning("arboard::platform::linux::x11")));
        assert!(!logger.enabled(&warning("winit::platform_impl::linux::x11::util::randr")));
        assert!(logger.enabled(&warning("meshtracer::app::tool")));
        let error = log::Metadata::builder().level(log::Level::Error).target("arboard").build();
        assert!(logger.enabled(&error), "the clipboard's errors still show");
    }
}
