//! Compiles the C++ shims in `ffi/` with cxx-build and links the Debian
//! libraries they wrap. Nothing but OpenVDB, OpenImageIO and OpenSubdiv crosses
//! the boundary.

fn main() {
    cxx_build::bridges([
        "ffi/openvdb/bridge.rs",
        "ffi/oiio/bridge.rs",
        "ffi/opensubdiv/bridge.rs",
    ])
    .files([
        "ffi/openvdb/shim.cc",
        "ffi/oiio/shim.cc",
        "ffi/opensubdiv/shim.cc",
    ])
    .std("c++17")
    .include("/usr/include/Imath")
    .flag_if_supported("-Wno-deprecated-declarations")
    .flag_if_supported("-Wno-unused-parameter")
    .compile("cirrus_ffi");

    // The linker on Debian 12 needs each of these named explicitly.
    for lib in [
        "openvdb",
        "tbb",
        "Imath-3_1",
        "OpenImageIO",
        "OpenImageIO_Util",
        "osdCPU",
    ] {
        println!("cargo:rustc-link-lib={lib}");
    }
    for path in [
        "ffi/guard.h",
        "ffi/openvdb/bridge.rs",
        "ffi/openvdb/shim.h",
        "ffi/openvdb/shim.cc",
        "ffi/oiio/bridge.rs",
        "ffi/oiio/shim.h",
        "ffi/oiio/shim.cc",
        "ffi/opensubdiv/bridge.rs",
        "ffi/opensubdiv/shim.h",
        "ffi/opensubdiv/shim.cc",
    ] {
        println!("cargo:rerun-if-changed={path}");
    }
}
