// The precompiled header of monomesh's targets (cmake/MonomeshHelpers.cmake, MM_PCH): the
// standard library and the heavy third-party headers most units include. Each part is guarded
// with __has_include, so a unit that falls back to reading this header as text (the compiler
// refused the .gch) still compiles. Parsing these headers took most of a typical unit's
// compile time (gcc -ftime-report: 50-75% in "phase parsing"); with the .gch a unit loads
// them in a fraction of a second. Nothing here may depend on a macro set per target.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <span>
#include <sstream>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#if __has_include(<Eigen/Dense>)
#include <Eigen/Dense>
#endif
#if __has_include(<opencv2/core.hpp>)
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/imgcodecs.hpp>
#endif
#if __has_include(<nlohmann/json.hpp>)
#include <nlohmann/json.hpp>
#endif
