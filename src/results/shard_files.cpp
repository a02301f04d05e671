#include "src/results/shard_files.hpp"

#include <array>
#include <cstring>
#include <fstream>

#include <sys/resource.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <zlib.h>

#include "src/core/error.hpp"
#include "src/io/files.hpp"
#include "src/io/json_problem.hpp"

namespace amhv::results {

namespace fs = std::filesystem;

namespace {

constexpr std::string_view kOutcomeMagic = "AMHVOUT1";
constexpr std::size_t kChunk = std::size_t(1) << 20;

// The piece's outcomes lie in blocks of one angle at one height: `visit(block start, block size)`
// in file order (heights, then angles).
template <typename Visit>
void for_each_block(const SweepResult& result, const ShardPiece& piece, Visit&& visit) {
    const PoseRange& r = result.range;
    const std::size_t per_angle = std::size_t(r.width()) * std::size_t(r.height());
    for (int l = r.z_first; l <= r.z_last; ++l)
        for (int k = piece.first_angle; k < piece.first_angle + piece.angle_count; ++k) visit(result.index(r.i_first, r.j_first, k, l), per_angle);
}

std::uint64_t piece_poses(const PoseRange& r, const ShardPiece& piece) {
    return std::uint64_t(r.width()) * std::uint64_t(r.height()) * std::uint64_t(piece.angle_count) * std::uint64_t(r.depth());
}

// Deflates into `out`, updating the CRC of what was written.
class DeflateWriter {
public:
    DeflateWriter(std::ofstream& out, const fs::path& path) : out_(out), path_(path), buffer_(kChunk) {
        if (deflateInit(&stream_, 1) != Z_OK) fail(path.string(), "zlib could not start");
    }
    ~DeflateWriter() { deflateEnd(&stream_); }
    void write(const std::uint8_t* data, std::size_t size, int flush) {
        stream_.next_in = const_cast<std::uint8_t*>(data);
        stream_.avail_in = uInt(size);
        do {
            stream_.next_out = buffer_.data();
            stream_.avail_out = uInt(buffer_.size());
            if (deflate(&stream_, flush) == Z_STREAM_ERROR) fail(path_.string(), "zlib failed");
            emit(buffer_.size() - stream_.avail_out);
        } while (stream_.avail_out == 0 || stream_.avail_in > 0);
    }
    void emit_raw(std::string_view bytes) {
        std::memcpy(buffer_.data(), bytes.data(), bytes.size());
        emit(bytes.size());
    }
    std::uint32_t crc() const { return crc_; }
    std::uint64_t bytes() const { return bytes_; }

private:
    void emit(std::size_t n) {
        out_.write(reinterpret_cast<const char*>(buffer_.data()), std::streamsize(n));
        crc_ = std::uint32_t(crc32(crc_, buffer_.data(), uInt(n)));
        bytes_ += n;
    }
    std::ofstream& out_;
    fs::path path_;
    std::vector<std::uint8_t> buffer_;
    z_stream stream_{};
    std::uint32_t crc_ = std::uint32_t(crc32(0, nullptr, 0));
    std::uint64_t bytes_ = 0;
};

// Inflates `source` (the file after its magic) into the piece's blocks of `result`; false when the
// stream is damaged or its length is not exactly the blocks'.
bool inflate_blocks(std::string_view source, SweepResult& result, const ShardPiece& piece) {
    z_stream stream{};
    if (inflateInit(&stream) != Z_OK) return false;
    stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(source.data()));
    stream.avail_in = uInt(source.size());
    bool ok = true;
    int status = Z_OK;
    for_each_block(result, piece, [&](std::size_t start, std::size_t size) {
        if (!ok) return;
        stream.next_out = reinterpret_cast<Bytef*>(result.outcomes.data() + start);
        stream.avail_out = uInt(size);
        while (stream.avail_out > 0 && status == Z_OK) status = inflate(&stream, Z_NO_FLUSH);
        ok = stream.avail_out == 0 && (status == Z_OK || status == Z_STREAM_END);
    });
    if (ok && status == Z_OK) {  // the stream must end exactly here
        std::uint8_t extra = 0;
        stream.next_out = &extra;
        stream.avail_out = 1;
        status = inflate(&stream, Z_FINISH);
        ok = status == Z_STREAM_END && stream.avail_out == 1;
    }
    ok = ok && stream.avail_in == 0;
    inflateEnd(&stream);
    return ok;
}

nlohmann::json range_json(const PoseRange& r) {
    return {{"i", {r.i_first, r.i_last}}, {"j", {r.j_first, r.j_last}}, {"z", {r.z_first, r.z_last}}, {"angles", r.angles}};
}

PoseRange range_of(const nlohmann::json& j) {
    PoseRange r;
    r.i_first = json_integer<int>(j.at("i").at(0)), r.i_last = json_integer<int>(j.at("i").at(1));
    r.j_first = json_integer<int>(j.at("j").at(0)), r.j_last = json_integer<int>(j.at("j").at(1));
    r.z_first = json_integer<int>(j.at("z").at(0)), r.z_last = json_integer<int>(j.at("z").at(1));
    r.angles = json_integer<int>(j.at("angles"));
    return r;
}

ShardPieceRecord piece_of(const nlohmann::json& j) {
    ShardPieceRecord p;
    p.piece.segment = json_integer<int>(j.at("segment"));
    p.piece.first_angle = json_integer<int>(j.at("angles").at(0));
    const std::int64_t last_angle = json_integer<int>(j.at("angles").at(1));
    p.piece.angle_count = int(std::clamp<std::int64_t>(last_angle - p.piece.first_angle + 1, 0, std::numeric_limits<int>::max()));
    p.range = range_of(j.at("range"));
    p.file = j.at("file").get<std::string>();
    p.poses = json_integer<std::uint64_t>(j.at("poses"));
    p.file_bytes = json_integer<std::uint64_t>(j.at("file_bytes"));
    p.crc32 = std::uint32_t(std::stoul(j.at("crc32").get<std::string>(), nullptr, 16));
    if (j.contains("sweep_s")) p.sweep_seconds = j.at("sweep_s").get<double>();
    return p;
}

// A file name a manifest may name: a plain name inside the shard folder.
bool plain_file_name(const std::string& name) {
    return !name.empty() && name.find('/') == std::string::npos && name != "." && name != ".." && name.find('\0') == std::string::npos;
}

}  // namespace

void write_piece_outcomes(const fs::path& folder, const SweepResult& result, ShardPieceRecord& record) {
    const ShardPiece& piece = record.piece;
    record.file = fmt::format("segment_{}_angles_{}-{}.outcomes", piece.segment, piece.first_angle, piece.first_angle + piece.angle_count - 1);
    record.range = result.range;
    record.poses = piece_poses(result.range, piece);
    const fs::path path = folder / record.file;
    std::ofstream out(path, std::ios::binary);
    if (!out) fail(path.string(), "cannot create the file");
    DeflateWriter writer(out, path);
    writer.emit_raw(kOutcomeMagic);
    for_each_block(result, piece, [&](std::size_t start, std::size_t size) {
        const auto* data = reinterpret_cast<const std::uint8_t*>(result.outcomes.data() + start);
        for (std::size_t done = 0; done < size; done += kChunk) writer.write(data + done, std::min(kChunk, size - done), Z_NO_FLUSH);
    });
    writer.write(nullptr, 0, Z_FINISH);
    finish_file(out, path);
    record.file_bytes = writer.bytes();
    record.crc32 = writer.crc();
}

void read_piece_outcomes(const fs::path& folder, const ShardPieceRecord& record, SweepResult& result) {
    const fs::path path = folder / record.file;
    if (!is_file(path)) fail(path.string(), "is missing: the shard is not whole (sweep it again)");
    const std::string bytes = read_file_bytes(path);
    if (bytes.size() != record.file_bytes)
        fail(path.string(), "has {} bytes where shard.json says {}: the file is damaged (sweep the shard again)", bytes.size(), record.file_bytes);
    const auto crc = std::uint32_t(crc32(crc32(0, nullptr, 0), reinterpret_cast<const Bytef*>(bytes.data()), uInt(bytes.size())));
    if (crc != record.crc32 || bytes.compare(0, kOutcomeMagic.size(), kOutcomeMagic) != 0)
        fail(path.string(), "its CRC-32 is {:08x} where shard.json says {:08x}: the file is damaged (sweep the shard again)", crc, record.crc32);
    if (record.poses != piece_poses(result.range, record.piece))
        fail(path.string(), "holds {} poses where the piece has {}", record.poses, piece_poses(result.range, record.piece));
    if (!inflate_blocks(std::string_view(bytes).substr(kOutcomeMagic.size()), result, record.piece))
        fail(path.string(), "does not inflate to the piece's {} outcomes: the file is damaged (sweep the shard again)", record.poses);
    bool valid = true;
    for_each_block(result, record.piece, [&](std::size_t start, std::size_t size) {
        for (std::size_t n = start; n < start + size; ++n) valid = valid && result.outcomes[n] <= PoseOutcome::Solution;
    });
    if (!valid) fail(path.string(), "holds values that are no pose outcome: the file is damaged (sweep the shard again)");
}

void write_shard_manifest(const fs::path& folder, const ShardManifest& m) {
    nlohmann::json pieces = nlohmann::json::array();
    for (const ShardPieceRecord& p : m.pieces) {
        nlohmann::json j = {{"segment", p.piece.segment},
                            {"angles", {p.piece.first_angle, p.piece.first_angle + p.piece.angle_count - 1}},
                            {"range", range_json(p.range)},
                            {"file", p.file},
                            {"poses", p.poses},
                            {"file_bytes", p.file_bytes},
                            {"crc32", fmt::format("{:08x}", p.crc32)}};
        if (m.timed) j["sweep_s"] = p.sweep_seconds;
        pieces.push_back(std::move(j));
    }
    nlohmann::json json = {{"kind", "amhv sweep shard"},
                           {"program", m.program},
                           {"scene", m.scene},
                           {"scene_hash", m.scene_hash},
                           {"inputs", m.inputs},
                           {"sampling", {{"voxel_m", m.voxel}, {"angle_step_deg", m.angle_step_deg}, {"angles", m.angles}}},
                           {"shard", {{"index", m.index}, {"count", m.count}}},
                           {"backend", m.backend},
                           {"device", m.device},
                           {"pieces", pieces}};
    if (m.timed) json["timings_s"] = {{"total", m.total_seconds}, {"peak_memory_mb", m.peak_memory_mb}};
    write_file(folder / kShardManifestFile, json.dump(2) + '\n');
}

ShardManifest read_shard_manifest(const fs::path& folder) {
    const fs::path file = folder / kShardManifestFile;
    const std::string where = file.string();
    if (!is_file(file)) fail(where, "is missing: {} is not a shard folder of `amhv sweep --shard`", folder.string());
    nlohmann::json json;
    try {
        json = nlohmann::json::parse(read_file_bytes(file));
    } catch (const nlohmann::json::exception& e) {
        fail(where, "is {}: the shard is damaged (sweep it again)", json_problem(e));
    }
    ShardManifest m;
    try {
        if (json.at("kind").get<std::string>() != "amhv sweep shard") fail(where, "is not a shard's manifest (kind is not \"amhv sweep shard\")");
        m.program = json.at("program").get<std::string>();
        m.scene = json.at("scene").get<std::string>();
        m.scene_hash = json.at("scene_hash").get<std::string>();
        m.inputs = json.at("inputs").get<std::string>();
        m.voxel = json.at("sampling").at("voxel_m").get<double>();
        m.angle_step_deg = json.at("sampling").at("angle_step_deg").get<double>();
        m.angles = json_integer<int>(json.at("sampling").at("angles"));
        m.index = json_integer<int>(json.at("shard").at("index"));
        m.count = json_integer<int>(json.at("shard").at("count"));
        m.backend = json.at("backend").get<std::string>();
        m.device = json.at("device").get<std::string>();
        for (const nlohmann::json& p : json.at("pieces")) m.pieces.push_back(piece_of(p));
        m.timed = json.contains("timings_s");
        if (m.timed) {
            m.total_seconds = json.at("timings_s").at("total").get<double>();
            m.peak_memory_mb = json.at("timings_s").at("peak_memory_mb").get<double>();
        }
    } catch (const nlohmann::json::exception& e) {
        fail(where, "is not a shard's manifest ({})", json_problem(e));
    } catch (const std::logic_error&) {  // std::stoul on a bad crc32
        fail(where, "is not a shard's manifest (its crc32 is not a hexadecimal number)");
    }
    if (m.count < 1 || m.index < 1 || m.index > m.count) fail(where, "shard {} of {} is no shard (K counts from 1 to N)", m.index, m.count);
    for (const ShardPieceRecord& p : m.pieces)
        if (!plain_file_name(p.file) || p.piece.angle_count < 1) fail(where, "piece of key segment {} is malformed", p.piece.segment);
    return m;
}

double peak_memory_mb() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return double(usage.ru_maxrss) / 1024.0;  // kilobytes on Linux
}

}  // namespace amhv::results
