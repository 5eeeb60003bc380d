//! Every WGSL program of the crate parses and validates with naga (no adapter needed),
//! in both float-accumulation variants.
use objectsplat_gpu::validate_wgsl;
use objectsplat_raster_gpu::FloatAtomics;
use objectsplat_raster_gpu::raster::raster_sources;

#[test]
fn every_shader_validates() {
    validate_wgsl("scan.wgsl", objectsplat_raster_gpu::scan::SCAN_WGSL).unwrap();
    validate_wgsl("sort.wgsl", objectsplat_raster_gpu::sort::SORT_WGSL).unwrap();
    use objectsplat_raster_gpu::training::{ADAM_WGSL, DEPTH_WGSL, FACES_WGSL, LOSS_WGSL};
    for (name, source) in [
        ("training/loss.wgsl", LOSS_WGSL),
        ("training/adam.wgsl", ADAM_WGSL),
        ("training/faces.wgsl", FACES_WGSL),
        ("training/depth.wgsl", DEPTH_WGSL),
    ] {
        validate_wgsl(name, source).unwrap();
    }
    for mode in [FloatAtomics::Native, FloatAtomics::CompareExchange] {
        for threads in [32, 64, 128, 256] {
            for (name, source) in raster_sources(mode, threads, threads) {
                validate_wgsl(name, &source)
                    .unwrap_or_else(|e| panic!("{mode:?}, {threads} threads: {e:#}"));
            }
        }
    }
}

#[test]
fn a_broken_shader_is_an_error_naming_it() {
    let err = validate_wgsl("broken.wgsl", "fn f() -> u32 { return 1.5; }").unwrap_err();
    assert!(format!("{err:#}").contains("broken.wgsl"), "{err:#}");
}
