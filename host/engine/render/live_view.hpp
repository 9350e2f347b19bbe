// A render in progress in tev (--display-server; io/display_client.hpp): the frame so far as the
// channels its EXR will hold. Shared by `render` (plain, adaptive, noise threshold) and `study`.
#pragma once

#include "io/display_client.hpp"
#include "io/exr.hpp"
#include "render/frame.hpp"

#include <memory>
#include <string>
#include <vector>

namespace vkmech {

// A client named "<name> (<pid>)", or none when `address` is empty. A failed connection is a warning
// on stderr now, and the render goes on.
std::unique_ptr<DisplayClient> open_live_view(const std::string& address, const std::string& name);

// Sends `frame` (with the descriptor's channels when `capture`, and `extra` after them) unless within
// DisplayClient::kInterval of the last send; `force`: the final image. A connection lost now is a
// warning once.
// `class_names`: a user taxonomy's classes (docs/lpe.md), which then name the channels; empty: the buckets.
void send_live_view(DisplayClient& display, const Frame& frame, bool capture, bool force,
                    const std::vector<ExrChannel>& extra = {}, const std::vector<std::string>& class_names = {});

}  // namespace vkmech
