use std::process::ExitCode;

use clap::Parser;

/// The x86 instruction sets this binary was compiled to use (`.cargo/config.toml`) that
/// a CPU may lack, by the names `is_x86_feature_detected!` knows.
#[cfg(target_arch = "x86_64")]
fn missing_instruction_sets() -> Vec<&'static str> {
    let mut missing = Vec::new();
    macro_rules! check {
        ($($name:tt),*) => {$(
            if cfg!(target_feature = $name) && !std::arch::is_x86_feature_detected!($name) {
                missing.push($name);
            }
        )*};
    }
    check!("avx2", "fma", "avx512f", "avx512dq", "avx512vl", "avx512bw");
    missing
}

fn main() -> ExitCode {
    #[cfg(target_arch = "x86_64")]
    {
        let missing = missing_instruction_sets();
        if !missing.is_empty() {
            eprintln!(
                "error: this grainflow binary was built for a CPU with {} (target-cpu=native on \
                 the build machine); rebuild it on this machine, or build a portable binary with \
                 RUSTFLAGS=\"-C target-cpu=x86-64-v3\" cargo build --release",
                missing.join(", ")
            );
            return ExitCode::from(1);
        }
    }
    grainflow::cli::main_with(grainflow::cli::Cli::parse())
}
