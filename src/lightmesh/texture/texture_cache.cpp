// texture_cache.cpp -- each image of a scene read once.
#include "lightmesh/texture/texture_cache.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <unistd.h>
#include <system_error>

#include "lightmesh/util/error.h"
#include "lightmesh/util/isolated_child.h"
#include "lightmesh/util/system.h"

namespace lm {
namespace {

std::string KeyOf(const TextureSource& s) {
    if (!s.file.empty()) {
        std::error_code ec;
        const std::filesystem::path canonical = std::filesystem::weakly_canonical(s.file, ec);
        return "file:" + (ec ? s.file : canonical.string());
    }
    return "embedded:" + std::to_string(s.rawWidth) + "x" + std::to_string(s.rawHeight) + ":" +
           std::to_string(s.bytes.size()) + ":" + std::to_string(std::hash<std::string>()(s.bytes));
}

/// The decoding child's deadline: ChildDeadlineSeconds of the images' bytes.
double DecodeSeconds(const std::vector<const TextureSource*>& sources) {
    uint64_t bytes = 0;
    for (const TextureSource* s : sources) {
        std::error_code ec;
        const auto size = s->file.empty() ? s->bytes.size() : std::filesystem::file_size(s->file, ec);
        if (!ec) bytes += size;
    }
    return ChildDeadlineSeconds(bytes);
}

enum : uint8_t { kDecoded = 1, kFailed = 2 };

// A decoded image's fields, in the order they are written and read (ChildFieldWriter):
// listed once, for both directions. D is DecodedImage, or const DecodedImage to write it.
template <typename Archive, typename D>
void DecodedImageFields(Archive& a, D& image) {
    a(image.width, image.height, image.ldr, image.hdr);
}

/// The child's record of one image: kDecoded and its texels, or kFailed and why it cannot
/// be read.
void WriteRecord(int fd, const TextureSource& source, const TextureCache::Decoder& decode) {
    ChildWriter w;
    DecodedImage image;
    const auto failed = [&](const std::string& why) {
        w = ChildWriter();
        w.Pod<uint8_t>(kFailed);
        w.Str(why);
    };
    try {
        image = decode(source);
        w.Pod<uint8_t>(kDecoded);
        ChildFieldWriter fields(&w);
        DecodedImageFields(fields, image);
    } catch (const std::bad_alloc&) {
        failed("decoding it needs more memory than this process may use");
    } catch (const std::exception& e) {
        failed(e.what());
    }
    if (!w.AppendTo(fd)) _exit(3);
}

/// Reads the record WriteRecord wrote of image `i`: *out[i] its texture, or *why[i] the
/// reason it cannot be read. Throws std::runtime_error on a record cut short or malformed.
void ReadRecord(ChildReader* r, size_t i, std::vector<std::shared_ptr<const Texture>>* out,
                std::vector<std::string>* why) {
    const uint8_t kind = r->Pod<uint8_t>();
    if (kind == kDecoded) {
        DecodedImage image;
        ChildFieldReader fields(r);
        DecodedImageFields(fields, image);
        if (!image.Consistent()) throw std::runtime_error("inconsistent texels");
        (*out)[i] = std::move(image).MakeTexture();
    } else if (kind == kFailed) {
        (*why)[i] = r->Str();
    } else {
        throw std::runtime_error("bad record");
    }
}

/// Decodes `todo` in child processes: *out[i] the texture of todo[i], or *why[i] the reason
/// it cannot be read. A child that crashes or runs past its deadline costs the image it was
/// decoding; the next child goes on with the rest.
void DecodeIsolated(const std::vector<const TextureSource*>& todo, const TextureCache::Decoder& decode,
                    std::vector<std::shared_ptr<const Texture>>* out, std::vector<std::string>* why) {
    out->assign(todo.size(), nullptr);
    why->assign(todo.size(), std::string());
    size_t next = 0;
    while (next < todo.size()) {
        const std::vector<const TextureSource*> rest(todo.begin() + static_cast<std::ptrdiff_t>(next), todo.end());
        const ChildLimits limits{PhysicalMemoryBytes() / 2, DecodeSeconds(rest)};
        const char* inProcess = std::getenv("LIGHTMESH_IMPORT_IN_PROCESS");
        const ChildOutcome child = inProcess && *inProcess && std::string(inProcess) != "0" ? ChildOutcome() : RunInChild("lightmesh-images", limits, [&](int fd) {
            for (const TextureSource* s : rest) WriteRecord(fd, *s, decode);
        });
        if (child.end == ChildOutcome::End::NotStarted) {  // no fork (or asked not to): decode here
            for (; next < todo.size(); ++next) try {
                    (*out)[next] = decode(*todo[next]).MakeTexture();
                } catch (const std::exception& e) {
                    (*why)[next] = e.what();
                }
            return;
        }
        ChildReader r(child.Bytes());
        try {
            while (next < todo.size() && !r.AtEnd()) {
                ReadRecord(&r, next, out, why);
                ++next;
            }
        } catch (const std::exception&) {
            // A record cut short: the child died while writing it.
        }
        if (next == todo.size()) return;
        // The child ended before the image `next`'s record was complete.
        switch (child.end) {
            case ChildOutcome::End::TimedOut:
                (*why)[next] = StringPrintf("the image decoder did not finish within %.0f s and was stopped "
                                            "(LIGHTMESH_IMPORT_TIMEOUT sets the limit in seconds)",
                                            child.seconds);
                break;
            case ChildOutcome::End::Signalled:
                (*why)[next] = StringPrintf("the image decoder crashed on it (signal %d, %s)%s", child.code,
                                            SignalName(child.code).c_str(), child.Said().c_str());
                break;
            default:
                (*why)[next] = StringPrintf("the image decoder crashed on it (exit status %d)", child.code);
                break;
        }
        ++next;
    }
}

}  // namespace

DecodedImage DecodeSource(const TextureSource& s) {
    if (!s.file.empty()) {
        if (const std::string problem = RegularFileProblem(s.file, "file"); !problem.empty())
            ThrowError("%s", problem.c_str());
        return ReadImageFile(s.file);
    }
    if (s.rawWidth > 0) {
        if (s.rawWidth > kMaxTextureSize || s.rawHeight < 1 || s.rawHeight > kMaxTextureSize ||
            s.bytes.size() != static_cast<size_t>(s.rawWidth) * static_cast<size_t>(s.rawHeight) * 4)
            ThrowError("its embedded texels are malformed");
        DecodedImage image;
        image.width = s.rawWidth, image.height = s.rawHeight;
        image.ldr.resize(s.bytes.size());
        for (size_t i = 0; i < image.ldr.size(); i += 4) {  // B, G, R, A to R, G, B, A
            image.ldr[i] = static_cast<uint8_t>(s.bytes[i + 2]);
            image.ldr[i + 1] = static_cast<uint8_t>(s.bytes[i + 1]);
            image.ldr[i + 2] = static_cast<uint8_t>(s.bytes[i]);
            image.ldr[i + 3] = static_cast<uint8_t>(s.bytes[i + 3]);
        }
        return image;
    }
    return DecodeImageBytes(s.bytes);
}

TextureCache::TextureCache() : decoder_(DecodeSource) {}

TextureCache::TextureCache(Decoder decoder) : decoder_(std::move(decoder)) {}

std::vector<int> TextureCache::GetAll(const std::vector<TextureSource>& sources, const std::string& model,
                                      std::vector<std::shared_ptr<const Texture>>* textures, const Warn& warn) {
    std::vector<std::string> keys;
    std::vector<const TextureSource*> todo;
    std::vector<std::string> todoKeys;
    for (const TextureSource& s : sources) {
        keys.push_back(KeyOf(s));
        if (!index_.count(keys.back()) &&
            std::find(todoKeys.begin(), todoKeys.end(), keys.back()) == todoKeys.end())
            todo.push_back(&s), todoKeys.push_back(keys.back());
    }
    if (!todo.empty()) {
        std::vector<std::shared_ptr<const Texture>> decoded;
        std::vector<std::string> why;
        DecodeIsolated(todo, decoder_, &decoded, &why);
        for (size_t i = 0; i < todo.size(); ++i) {
            int index = -1;
            if (decoded[i]) {
                textures->push_back(std::move(decoded[i]));
                index = static_cast<int>(textures->size() - 1);
            } else {
                // Error's what() is the reason alone here (ThrowError names no file).
                warn(model + ": texture \"" + todo[i]->name + "\": " + why[i] + "; the material's flat colour is used");
            }
            index_[todoKeys[i]] = index;
        }
    }
    std::vector<int> indices;
    for (const std::string& key : keys) indices.push_back(index_.at(key));
    return indices;
}

int TextureCache::Get(const TextureSource& source, const std::string& model,
                      std::vector<std::shared_ptr<const Texture>>* textures, const Warn& warn) {
    return GetAll({source}, model, textures, warn)[0];
}

}  // namespace lm
