// The translation unit that builds the libraries' precompiled header (cmake/RigTargets.cmake).
