// Downstream sample allocation (docs/descriptor.md §6, paper §7 "Downstream
// Demonstration"): strategies, the bucket floor and its placebo, the
// median-of-means variance, Neyman allocation, the pilot's guard rails, and
// the error metrics.
// Pure C++, no Vulkan.
#pragma once

#include "allocation/adaptive_mom.hpp"
#include "allocation/floor.hpp"
#include "allocation/guard.hpp"
#include "allocation/metrics.hpp"
#include "allocation/mom.hpp"
#include "allocation/neyman.hpp"
#include "allocation/plan.hpp"
#include "allocation/strategy.hpp"
#include "allocation/threshold.hpp"
