//! The command line: a thin layer that parses flags and calls the library.

pub mod args;
pub mod bench;
pub mod render;
pub mod view;

pub use args::{Cli, Command};

/// `meshtracer devices`: print the Vulkan devices with their indices.
pub fn devices() -> anyhow::Result<()> {
    for (i, name) in crate::gpu::context::list_devices()?.iter().enumerate() {
        println!("{i}: {name}");
    }
    Ok(())
}
