#include "io/exr.hpp"

#include "io/atomic_file.hpp"

#include <Imath/half.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfStringVectorAttribute.h>
#include <OpenEXR/ImfThreading.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <thread>

#include <unistd.h>

namespace vkmech {

namespace {

constexpr const char* kOrderAttribute = "vkmech.channelOrder";

// An Imf::OStream over a file descriptor owned by write_file_atomic_with.
// Errors are thrown *and* remembered: OutputFile's destructor writes the
// line-offset table and swallows exceptions, so the writer checks failed()
// after the OutputFile is gone.
class FdOStream final : public Imf::OStream {
public:
    FdOStream(int fd, const std::string& name) : Imf::OStream(name.c_str()), fd_(fd) {}

    void write(const char c[], int n) override {
        if (n < 0) fail("negative write size");
        try {
            write_all_fd(fd_, c, static_cast<size_t>(n));
        } catch (const std::exception& e) {
            fail(e.what());
        }
        pos_ += static_cast<uint64_t>(n);
    }
    uint64_t tellp() override { return pos_; }
    void seekp(uint64_t pos) override {
        if (::lseek(fd_, static_cast<off_t>(pos), SEEK_SET) == static_cast<off_t>(-1))
            fail(std::string("seek failed: ") + std::strerror(errno));
        pos_ = pos;
    }

    void throw_if_failed() const {
        if (!error_.empty()) throw std::runtime_error(error_);
    }

private:
    [[noreturn]] void fail(const std::string& what) {
        if (error_.empty()) error_ = what;
        throw std::runtime_error(what);
    }

    int fd_;
    uint64_t pos_ = 0;
    std::string error_;
};

// ZIP (de)compression is the cost of large EXRs; OpenEXR parallelises it over
// its global thread pool, which is empty by default. Enable it once, unless
// the application has already chosen a thread count.
int exr_threads() {
    static std::once_flag once;
    std::call_once(once, [] {
        if (Imf::globalThreadCount() == 0) {
            const unsigned hw = std::thread::hardware_concurrency();
            Imf::setGlobalThreadCount(static_cast<int>(std::clamp(hw, 1u, 8u)));
        }
    });
    return Imf::globalThreadCount();
}

[[noreturn]] void fail(const std::string& path, const std::string& why) {
    throw std::runtime_error("cannot write '" + path + "': " + why);
}

}  // namespace

void write_exr_layers(const std::string& path, int width, int height, const std::vector<ExrChannel>& channels,
                      const std::map<std::string, std::vector<std::string>>& attributes) {
    if (width <= 0 || height <= 0) fail(path, "invalid size " + std::to_string(width) + "x" + std::to_string(height));
    if (channels.empty()) fail(path, "no channels");
    const size_t n = static_cast<size_t>(width) * static_cast<size_t>(height);

    Imf::Header header(width, height);
    header.compression() = Imf::ZIP_COMPRESSION;
    header.lineOrder() = Imf::INCREASING_Y;
    std::vector<std::string> order;
    order.reserve(channels.size());
    for (const ExrChannel& c : channels) {
        if (c.name.empty()) fail(path, "empty channel name");
        if (c.data.size() != n)
            fail(path, "channel '" + c.name + "' has " + std::to_string(c.data.size()) + " values, expected " +
                           std::to_string(n));
        if (header.channels().findChannel(c.name)) fail(path, "duplicate channel name '" + c.name + "'");
        header.channels().insert(c.name, Imf::Channel(c.half ? Imf::HALF : Imf::FLOAT));
        order.push_back(c.name);
    }
    header.insert(kOrderAttribute, Imf::StringVectorAttribute(order));
    for (const auto& [name, values] : attributes) {
        if (name.empty() || name == kOrderAttribute) fail(path, "invalid header attribute name '" + name + "'");
        if (name == kCapDateAttribute) {
            // OpenEXR's standard capture date (a string "YYYY:MM:DD HH:MM:SS")
            // with its utcOffset: the date is UTC.
            if (values.size() != 1 || values[0].size() != 19) fail(path, "capDate must be one 'YYYY:MM:DD HH:MM:SS'");
            Imf::addCapDate(header, values[0]);
            Imf::addUtcOffset(header, 0.0f);
            continue;
        }
        header.insert(name, Imf::StringVectorAttribute(values));
    }

    // Half channels are converted up front; float channels are written in place.
    std::vector<std::vector<half>> halves;
    Imf::FrameBuffer fb;
    const size_t xs_f = sizeof(float), xs_h = sizeof(half);
    for (const ExrChannel& c : channels) {
        if (c.half) {
            std::vector<half>& h = halves.emplace_back(n);
            for (size_t i = 0; i < n; ++i) h[i] = half(c.data[i]);
            fb.insert(c.name, Imf::Slice(Imf::HALF, reinterpret_cast<char*>(h.data()), xs_h, xs_h * width));
        } else {
            fb.insert(c.name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(const_cast<float*>(c.data.data())), xs_f,
                                         xs_f * width));
        }
    }

    write_file_atomic_with(path, [&](int fd, const std::string& tmp) {
        FdOStream os(fd, tmp);
        {
            Imf::OutputFile file(os, header, exr_threads());
            file.setFrameBuffer(fb);
            file.writePixels(height);
        }  // the destructor writes the line-offset table
        os.throw_if_failed();
    });
}

namespace {

std::map<std::string, std::vector<std::string>> string_attributes(const Imf::Header& header) {
    std::map<std::string, std::vector<std::string>> out;
    for (auto it = header.begin(); it != header.end(); ++it) {
        if (const auto* sv = dynamic_cast<const Imf::StringVectorAttribute*>(&it.attribute()))
            out[it.name()] = sv->value();
        else if (const auto* st = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
            out[it.name()] = {st->value()};
    }
    return out;
}

}  // namespace

std::map<std::string, std::vector<std::string>> read_exr_attributes(const std::string& path) {
    try {
        Imf::InputFile file(path.c_str(), exr_threads());
        return string_attributes(file.header());
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot read EXR '" + path + "': " + e.what());
    }
}

// Limits on what read_exr_channels allocates from a header's claims.
constexpr int64_t kMaxExrSide = 65536;
constexpr uint64_t kMaxExrBytes = uint64_t{4} << 30;

ExrImage read_exr_channels(const std::string& path) {
    try {
        Imf::InputFile file(path.c_str(), exr_threads());
        const Imf::Header& header = file.header();
        const Imath::Box2i dw = header.dataWindow();
        ExrImage img;
        // In 64 bits: a hostile window (min -2^31, max 2^31 - 1) overflows int.
        const int64_t w64 = int64_t{dw.max.x} - dw.min.x + 1, h64 = int64_t{dw.max.y} - dw.min.y + 1;
        if (w64 <= 0 || h64 <= 0) throw std::runtime_error("empty data window");
        // The header's size is checked before anything is allocated.
        size_t channel_count = 0;
        for (auto it = header.channels().begin(); it != header.channels().end(); ++it) ++channel_count;
        if (w64 > kMaxExrSide || h64 > kMaxExrSide ||
            static_cast<uint64_t>(w64 * h64) * std::max<size_t>(channel_count, 1) * sizeof(float) > kMaxExrBytes)
            throw std::runtime_error("the header claims " + std::to_string(w64) + " x " + std::to_string(h64) +
                                     " pixels x " + std::to_string(channel_count) +
                                     " channels, more than vkmech reads (" + std::to_string(kMaxExrSide) +
                                     " per side, " + std::to_string(kMaxExrBytes >> 30) + " GiB as float)");
        img.width = static_cast<int>(w64);
        img.height = static_cast<int>(h64);
        const size_t n = static_cast<size_t>(img.width) * static_cast<size_t>(img.height);

        Imf::FrameBuffer fb;
        std::vector<std::string> file_order;
        for (auto it = header.channels().begin(); it != header.channels().end(); ++it) {
            const std::string name = it.name();
            const Imf::Channel& ch = it.channel();
            if (ch.xSampling != 1 || ch.ySampling != 1)
                throw std::runtime_error("subsampled channel '" + name + "' is not supported");
            file_order.push_back(name);
            if (ch.type == Imf::HALF) img.half_channels.insert(name);
            std::vector<float>& data = img.channels[name];
            data.assign(n, 0.0f);
            fb.insert(name, Imf::Slice::Make(Imf::FLOAT, data.data(), dw, sizeof(float), sizeof(float) * img.width));
        }
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);

        img.order = file_order;
        if (const auto* attr = header.findTypedAttribute<Imf::StringVectorAttribute>(kOrderAttribute)) {
            const std::vector<std::string>& rec = attr->value();
            bool valid = rec.size() == file_order.size();
            std::set<std::string> seen;
            for (const std::string& s : rec) valid = valid && img.channels.count(s) == 1 && seen.insert(s).second;
            if (valid) img.order = rec;
        }
        img.attributes = string_attributes(header);
        return img;
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot read EXR '" + path + "': " + e.what());
    }
}

}  // namespace vkmech
