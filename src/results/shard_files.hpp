#pragma once
// A shard folder of `amhv sweep --shard K/N` (docs/design.md, "Scale-out"): shard.json says what
// the shard is (program, scene and its hash, sampling, K of N, backend) and which angles of which
// key segments it swept; beside it, one file of pose outcomes per piece, deflated (zlib), with a
// CRC-32 in shard.json so that `amhv merge` refuses a damaged file instead of merging it.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "src/sweep/problem.hpp"

namespace amhv::results {

// A shard's share of one key segment: the angles k in [first_angle, first_angle + angle_count).
struct ShardPiece {
    int segment = 0, first_angle = 0, angle_count = 0;
    bool operator==(const ShardPiece&) const = default;
};

// A piece as its shard swept it.
struct ShardPieceRecord {
    ShardPiece piece;
    PoseRange range;             // the key segment's poses (all its angles); merge checks its own
    std::string file;            // the outcomes, relative to the shard folder
    std::uint64_t poses = 0;     // outcomes in the file: the piece's angles only
    std::uint64_t file_bytes = 0;
    std::uint32_t crc32 = 0;     // of the file's bytes
    double sweep_seconds = 0;
};

struct ShardManifest {
    std::string program, scene, scene_hash;
    std::string inputs;  // fingerprint of the scene's input files (pipeline::inputs_fingerprint)
    double voxel = 0, angle_step_deg = 0;
    int angles = 0;
    int index = 0, count = 0;  // shard K of N, K from 1
    std::string backend, device;
    std::vector<ShardPieceRecord> pieces;
    bool timed = false;  // the figures below were measured (not with --no-timings)
    double total_seconds = 0, peak_memory_mb = 0;
};

inline constexpr const char* kShardManifestFile = "shard.json";

// Writes the outcomes of `result` at the piece's angles (every height) into folder/record.file,
// filling the record's poses, file_bytes and crc32.
void write_piece_outcomes(const std::filesystem::path& folder, const SweepResult& result, ShardPieceRecord& record);

// Reads a piece's outcomes into `result`, whose range and outcomes are already the key segment's.
// Throws amhv::Error naming the file when it is missing, of another size, damaged or holds values
// that are no outcome.
void read_piece_outcomes(const std::filesystem::path& folder, const ShardPieceRecord& record, SweepResult& result);

void write_shard_manifest(const std::filesystem::path& folder, const ShardManifest& manifest);
// Throws amhv::Error "FOLDER/shard.json: ..." when the file is missing, not JSON or not a manifest.
ShardManifest read_shard_manifest(const std::filesystem::path& folder);

// Peak resident memory of this process so far, in MB (getrusage).
double peak_memory_mb();

}  // namespace amhv::results
