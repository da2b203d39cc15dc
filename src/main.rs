//! The `meshtracer` binary: parse the command line, run, and turn any error into one line.

use meshtracer::cli::{self, Cli, Command};

fn main() {
    // A write past `ulimit -f` then fails as one error line and leaves no temporary file.
    meshtracer::files::ignore_file_size_signal();
    // Every warning reaches the terminal once, through the logger, as "warning: ...".
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or(cli::LOG_FILTER))
        .format(|out, record| {
            use std::io::Write;
            let level = match record.level() {
                log::Level::Warn => "warning".to_string(),
                other => other.as_str().to_lowercase(),
            };
            writeln!(out, "{level}: {}", record.args())
        })
        .init();
    // A bug must still end in one readable line, not a backtrace.
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into());
        let at =
            info.location().map(|l| format!(" at {}:{}", l.file(), l.line())).unwrap_or_default();
        eprintln!("error: internal error: {msg}{at} (please report this)");
    }));
    let cli = match Cli::try_parse_noting_flags() {
        Ok(cli) => cli,
        // --help and --version print as usual; a bad flag is one line, not a page.
        Err(e) if !e.use_stderr() => e.exit(),
        Err(e) => {
            let text = e.to_string();
            let parts: Vec<&str> = text
                .lines()
                .map(str::trim)
                .filter(|l| {
                    !l.is_empty()
                        && !l.starts_with("For more information")
                        && !l.starts_with("Usage:")
                })
                .collect();
            eprintln!("{}", parts.join(" "));
            std::process::exit(2);
        }
    };
    let result = match cli.command {
        Some(Command::Render(args)) => cli::render::run(&args),
        Some(Command::Bench(args)) => cli::bench::run(&args),
        Some(Command::Devices) => cli::devices(),
        Some(Command::View(args)) => args.options().and_then(|o| meshtracer::app::run(&o)),
        None => cli.view.options().and_then(|o| meshtracer::app::run(&o)),
    };
    if let Err(e) = result {
        eprintln!("error: {}", one_line(&e));
        std::process::exit(1);
    }
}

/// The error and its causes on one line, skipping a cause whose text the line already
/// holds (our errors often quote their source).
fn one_line(e: &anyhow::Error) -> String {
    let mut line = e.to_string();
    for cause in e.chain().skip(1) {
        let text = cause.to_string();
        if !line.contains(&text) {
            line.push_str(": ");
            line.push_str(&text);
        }
    }
    line.replace('\n', " ")
}
