// Compact storage of the contacts of an interface (issue #25; docs/interfaces.md, "Memory
// layout"). A Contact keeps its memory in growable vectors, a config and step scratch: about
// 2 kB per Hertz asperity once allocated. An interface holds up to 10^7 of them, and each needs
// only its state: four scalars and a polyline of a handful of vertices. Here each contact is one
// fixed-size record (the scalars and, inline, its memory encoded without loss); a memory that
// does not fit lives in a heap block of its own. Work on a contact decodes it into a Contact
// (ContactCursor, one per worker range, reused), steps or reads it, and encodes it back: the
// engine is the single contact's, so the results are bit for bit those of a Contact.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <type_traits>
#include <unordered_map>
#include <vector>

#include "mdr/core/contact.h"

namespace mdr {

class PackedContacts {
 public:
  // A record: depth, tangential displacement, the two energies, the config's index, the vertex
  // count, the encoding's length and the encoding itself inline when it fits kInlineBytes (a
  // Hertz asperity in Mindlin-Deresiewicz cycling needs 55 to 81 bytes), else a pointer to its
  // heap block.
  static constexpr std::size_t kRecordBytes = 128;
  static constexpr std::size_t kInlineBytes = kRecordBytes - 4 * sizeof(double) - 3 * 4;

  PackedContacts() = default;
  // n records of contacts out of contact (depth 0, no memory, energies 0) with config 0.
  explicit PackedContacts(std::size_t n);
  // n records left unwritten (a step's new records: the workers write them in parallel, where
  // the memory is first touched). Each must be Clear()ed or Put before anything else reads or
  // destroys it.
  static PackedContacts Unwritten(std::size_t n);
  // Frees every heap block: each record keeps its scalars and holds no memory encoding (a
  // valid record to Put over, not a state to read).
  void ReleaseBlocks() { FreeBlocks(); }
  // Makes record i a valid empty one (no heap block), without looking at what it held.
  void Clear(std::size_t i) {
    records_[i].bytes = 0;
    records_[i].vertices = 0;
  }
  PackedContacts(const PackedContacts& other);
  PackedContacts& operator=(const PackedContacts& other);
  PackedContacts(PackedContacts&& other) noexcept;
  PackedContacts& operator=(PackedContacts&& other) noexcept;
  ~PackedContacts();

  std::size_t size() const { return size_; }
  double depth(std::size_t i) const { return records_[i].depth; }
  double tangential_displacement(std::size_t i) const { return records_[i].ux; }
  double dissipated_energy(std::size_t i) const { return records_[i].dissipated; }
  double last_step_dissipation(std::size_t i) const { return records_[i].last_dissipated; }
  std::uint32_t config_index(std::size_t i) const { return records_[i].config; }
  // Vertices of the exact memory (0 for a grid contact).
  std::size_t vertex_count(std::size_t i) const { return records_[i].vertices; }

  // Encodes `contact` into record i with the given config index (reusing the record's heap
  // block when the encoding fits it). Safe to call concurrently for distinct i.
  void Put(std::size_t i, const Contact& contact, std::uint32_t config);
  // Decodes record i into *contact, whose config must be the record's (ContactCursor sees to it).
  void Get(std::size_t i, Contact* contact) const;

  // Bytes held: the records and the heap blocks.
  std::size_t MemoryBytes() const {
    return size_ * sizeof(Record) + heap_bytes_.load(std::memory_order_relaxed);
  }
  // Bytes in heap blocks (memories longer than kInlineBytes).
  std::size_t heap_bytes() const { return heap_bytes_.load(std::memory_order_relaxed); }

 private:
  // Trivial, so that an array of them can be left unwritten (Unwritten); all zero bytes: an
  // empty record.
  struct Record {
    double depth, ux, dissipated, last_dissipated;
    std::uint32_t config;
    std::uint32_t vertices;
    std::uint32_t bytes;  // length of the encoding; > kInlineBytes: in a heap block
    // The encoding, or (bytes > kInlineBytes) the block's pointer and capacity.
    alignas(4) unsigned char data[kInlineBytes];
  };
  static_assert(sizeof(Record) == kRecordBytes);
  static_assert(std::is_trivial_v<Record>);

  // Room for an encoding of `bytes` in record i (inline, its heap block, or a new one); sets
  // the record's length.
  unsigned char* Reserve(Record& r, std::size_t bytes);
  unsigned char* Block(const Record& r) const;
  std::uint32_t BlockCapacity(const Record& r) const;
  void FreeBlock(Record& r);
  void FreeBlocks();
  void CopyFrom(const PackedContacts& other);

  // Record arrays come from AllocateRecords (aligned; std::free releases them).
  struct FreeRecords {
    void operator()(Record* records) const;
  };
  static std::unique_ptr<Record[], FreeRecords> AllocateRecords(std::size_t n);

  std::unique_ptr<Record[], FreeRecords> records_;
  std::size_t size_ = 0;
  std::atomic<std::size_t> heap_bytes_{0};
};

// The configs of a store's contacts, each distinct one once, by index (PackedContacts::
// config_index). A rough surface gives each summit a radius of its own, so its contacts differ
// in their profiles only: the rest of a config (its settings, 112 bytes) is kept once per
// distinct value, and a distinct config costs a 16-byte entry naming its profile and settings.
class ConfigTable {
 public:
  // The index of config's entry: an existing one with the same config (SameConfig), or a new
  // one (*added). Validation is the caller's.
  std::uint32_t Add(const ContactConfig& config, bool* added);
  // Drops what Add needs to find configs (Add may not be called after it) and spare capacity.
  void FinishAdding();

  std::size_t size() const { return entries_.size(); }
  // Entry k's config: a copy that owns its profile (for a Contact that may outlive the table).
  ContactConfig Config(std::uint32_t k) const;
  // Entry k's config but for its profile, and its settings' index (entries with equal settings
  // share it).
  const ContactConfig& settings(std::uint32_t k) const { return settings_[entries_[k].settings]; }
  std::uint32_t settings_index(std::uint32_t k) const { return entries_[k].settings; }
  const Profile& profile(std::uint32_t k) const { return *entries_[k].profile; }
  // A pointer to entry k's profile that does not own it (copies touch no reference count):
  // valid while the table lives.
  ProfilePtr BorrowedProfile(std::uint32_t k) const {
    return ProfilePtr(ProfilePtr(), entries_[k].profile);
  }
  // The number of distinct profiles.
  std::size_t profiles() const { return profile_count_; }
  // Bytes held: entries, settings, owning pointers and the profiles themselves.
  std::size_t MemoryBytes() const;

 private:
  struct Entry {
    const Profile* profile;
    std::uint32_t settings;
    std::uint32_t owner;  // the element of owners_ that owns the profile
  };
  static_assert(sizeof(Entry) == 16);

  std::vector<ContactConfig> settings_;  // profile fields null
  std::vector<Entry> entries_;
  // One owning pointer per allocation (the spheres of MakeSpheres share one).
  std::vector<ProfilePtr> owners_;
  std::size_t profile_count_ = 0, profile_bytes_ = 0;
  // Add's indexes, until FinishAdding.
  std::unordered_map<std::size_t, std::vector<std::uint32_t>> settings_by_hash_;
  std::unordered_map<const Profile*, std::vector<std::uint32_t>> entries_by_profile_;
};

// One contact of a PackedContacts decoded for work: one cursor per range of contacts on a
// worker, reused from contact to contact, so that decoding allocates nothing once its vectors
// have grown, and switching to a contact of other settings or another profile copies the
// settings or a borrowed profile pointer only. The cursor's contact borrows its profile: use it
// while the table lives (Copy for one that may outlive it).
class ContactCursor {
 public:
  explicit ContactCursor(const ConfigTable& configs) : configs_(&configs) {}
  // Contact i, decoded.
  Contact& Load(const PackedContacts& store, std::size_t i);
  // Contact i, decoded into a contact of its own that owns its profile.
  Contact Copy(const PackedContacts& store, std::size_t i);
  // A contact with config `config` out of contact (depth 0, no memory, energies 0).
  Contact& Fresh(std::uint32_t config);

 private:
  void Bind(std::uint32_t config);

  const ConfigTable* configs_;
  std::optional<Contact> contact_;
  std::uint32_t bound_ = 0;
};

}  // namespace mdr
