// The donor unit of a precompiled header (cmake/MonomeshHelpers.cmake, MM_PCH).
