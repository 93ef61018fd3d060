use std::process::ExitCode;

use clap::Parser;

/// The x86 instruction sets this binary was compiled to use (`.cargo/config.toml`) that
/// a CPU may lack, by the names `is_x86_feature_detected!` knows.
#[cfg(target_arch = "x86_64")]
fn missing_instruction_sets() -> Vec<&'static str> {
    use std::arch::is_x86_feature_detected as has;
    [
        (cfg!(target_feature = "avx2"), "avx2", has!("avx2")),
        (cfg!(target_feature = "fma"), "fma", has!("fma")),
        (cfg!(target_feature = "avx512f"), "avx512f", has!("avx512f")),
        (
            cfg!(target_feature = "avx512dq"),
            "avx512dq",
            has!("avx512dq"),
        ),
        (
            cfg!(target_feature = "avx512vl"),
            "avx512vl",
            has!("avx512vl"),
        ),
        (
            cfg!(target_feature = "avx512bw"),
            "avx512bw",
            has!("avx512bw"),
        ),
    ]
    .into_iter()
    .filter(|&(built, _, present)| built && !present)
    .map(|(_, name, _)| name)
    .collect()
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
