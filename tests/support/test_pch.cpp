// Anchor of the precompiled GoogleTest header that every test executable reuses (cmake/RigTargets.cmake).
