//! `bench --load`'s memory per phase: the kernel's peak is read and reset at every phase
//! boundary. Alone in its test binary: the peak is the whole process's, and tests running
//! beside it in one process would add theirs.

use meshtracer::progress::{Phase, Progress};

#[test]
fn each_phase_gets_its_own_peak() {
    // A phase that allocates 64 MB has a peak above the next phase's, which starts after
    // the memory is gone.
    if !cfg!(target_os = "linux") {
        return;
    }
    let progress = Progress::default();
    progress.track_peak_memory();
    progress.begin(Phase::Parse).unwrap();
    let big = vec![1u8; 64 << 20];
    std::hint::black_box(&big);
    drop(big);
    progress.begin(Phase::Build).unwrap();
    progress.finish();
    let phases = progress.snapshot().phases;
    let (parse, build) = (phases[0].peak_rss_bytes.unwrap(), phases[1].peak_rss_bytes.unwrap());
    assert!(parse >= build + (48 << 20), "parse peak {parse} against build {build}");
}
