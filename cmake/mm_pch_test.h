// The precompiled header of the tests (cmake/MonomeshHelpers.cmake, MM_PCH): mm_pch.h and
// GoogleTest.
#pragma once

#include "mm_pch.h"

#if __has_include(<gtest/gtest.h>)
#include <gtest/gtest.h>
#endif
