#include "render/live_view.hpp"

#include "render/descriptor.hpp"
#include "render/render_outputs.hpp"

#include <unistd.h>

#include <cstdio>
#include <optional>

namespace vkmech {

std::unique_ptr<DisplayClient> open_live_view(const std::string& address, const std::string& name) {
    if (address.empty()) return nullptr;
    auto client = std::make_unique<DisplayClient>(address, name + " (" + std::to_string(::getpid()) + ")");
    if (!client->connected()) std::fprintf(stderr, "vkmech: warning: %s\n", client->warning().c_str());
    return client;
}

void send_live_view(DisplayClient& display, const Frame& frame, bool capture, bool force,
                    const std::vector<ExrChannel>& extra, const std::vector<std::string>& class_names) {
    if (!display.connected() || !display.due(force)) return;
    std::optional<Descriptor> desc;
    if (capture) desc = derive_descriptor(frame);
    if (desc && !class_names.empty()) use_taxonomy_classes(*desc, class_names);
    std::vector<ExrChannel> channels = render_channels(frame, desc ? &*desc : nullptr);
    channels.insert(channels.end(), extra.begin(), extra.end());
    display.update(frame.width, frame.height, channels, force);
    if (!display.connected()) std::fprintf(stderr, "vkmech: warning: %s\n", display.warning().c_str());
}

}  // namespace vkmech
