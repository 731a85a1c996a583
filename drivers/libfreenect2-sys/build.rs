//! Compiles the C++ shim, against the real libfreenect2 (`freenect2` feature, found by
//! pkg-config) or the fake one in `fake/` (`fake` feature); without either, nothing is built.

fn main() {
    println!("cargo:rerun-if-changed=shim");
    println!("cargo:rerun-if-changed=fake");
    #[cfg(feature = "freenect2")]
    {
        let lib = match pkg_config::Config::new()
            .atleast_version("0.2")
            .probe("freenect2")
        {
            Ok(lib) => lib,
            Err(e) => {
                println!(
                    "cargo:warning=libfreenect2 not found by pkg-config ({e}); build it from \
                     https://github.com/OpenKinect/libfreenect2 and set PKG_CONFIG_PATH"
                );
                std::process::exit(1);
            }
        };
        let mut build = cc::Build::new();
        build
            .cpp(true)
            .std("c++14")
            .file("shim/shim.cpp")
            .include("shim");
        for dir in &lib.include_paths {
            build.include(dir);
        }
        build.compile("trigait_freenect2_shim");
    }
    #[cfg(all(feature = "fake", not(feature = "freenect2")))]
    {
        cc::Build::new()
            .cpp(true)
            .std("c++14")
            .define("TRIGAIT_FAKE_FREENECT2", None)
            .include("shim")
            .include("fake/include")
            .file("shim/shim.cpp")
            .file("fake/src/fake.cpp")
            .compile("trigait_freenect2_fake");
        println!("cargo:rustc-cfg=fake_library");
    }
    println!("cargo::rustc-check-cfg=cfg(fake_library)");
}
