#include "mdr/core/packed_contacts.h"

#include <algorithm>
#include <bit>
#include <cstdlib>
#include <cstring>
#include <new>
#include <utility>

#ifdef __linux__
#include <sys/mman.h>
#endif

namespace mdr {
namespace {

// The encodings (docs/interfaces.md, "Memory layout"). Byte 0 is the format: the kind in bits
// 0-1 and, for the compact kind, which of the polyline's fixed ends are stored (an end is left
// out only when its bits are exactly what it must be: z_0 = +0, z_n-1 = depth, u_n-1 = +0).
constexpr unsigned char kCompact = 0;  // exact memory, anchors in a table of at most 15
constexpr unsigned char kRaw = 1;      // exact memory, every value as it is
constexpr unsigned char kGrid = 2;     // grid memory, every spring as it is
constexpr unsigned char kKindMask = 3;
constexpr unsigned char kFirstZStored = 4;
constexpr unsigned char kLastZStored = 8;
constexpr unsigned char kLastUStored = 16;
// A compact table entry: the bound in bits 0-1; the anchor's ux and depth are the contact's
// current ones (not stored) when bits 2 and 3 are set.
constexpr unsigned char kCurrentUx = 4;
constexpr unsigned char kCurrentDepth = 8;
constexpr std::size_t kMaxTable = 15;  // indices are nibbles; 0 is the empty anchor
// An encoded anchor of the raw and grid kinds: bound, ux, depth.
constexpr std::size_t kAnchorBytes = 1 + 2 * sizeof(double);

bool IsEmptyAnchor(const SegmentAnchor& a) {
  return a.bound == kInside && SameBits(a.tangential_displacement, 0.0) && SameBits(a.depth, 0.0);
}

bool SameAnchor(const SegmentAnchor& a, const SegmentAnchor& b) {
  return a.bound == b.bound && SameBits(a.tangential_displacement, b.tangential_displacement) &&
         SameBits(a.depth, b.depth);
}

// Writes and reads values at a moving position (unaligned: memcpy).
class Writer {
 public:
  explicit Writer(unsigned char* at) : at_(at) {}
  void Byte(unsigned char b) { *at_++ = b; }
  void Double(double v) {
    std::memcpy(at_, &v, sizeof v);
    at_ += sizeof v;
  }
  unsigned char* at() { return at_; }
  void Skip(std::size_t n) { at_ += n; }

 private:
  unsigned char* at_;
};

class Reader {
 public:
  explicit Reader(const unsigned char* at) : at_(at) {}
  unsigned char Byte() { return *at_++; }
  double Double() {
    double v;
    std::memcpy(&v, at_, sizeof v);
    at_ += sizeof v;
    return v;
  }
  const unsigned char* at() const { return at_; }
  void Skip(std::size_t n) { at_ += n; }

 private:
  const unsigned char* at_;
};

void WriteAnchor(Writer& w, const SegmentAnchor& a) {
  w.Byte(a.bound);
  w.Double(a.tangential_displacement);
  w.Double(a.depth);
}

SegmentAnchor ReadAnchor(Reader& r) {
  SegmentAnchor a;
  a.bound = static_cast<BoundTag>(r.Byte());
  a.tangential_displacement = r.Double();
  a.depth = r.Double();
  return a;
}

// The compact encoding of an exact memory of n >= 2 vertices, after the format byte: the tags
// (2 bits each), the anchor indices (a nibble each: 0 the empty anchor, k entry k of the table),
// z_1 .. z_n-2, u_0 .. u_n-2, the stored ends, then the table: its size, a kind byte per entry
// (the bound; whether the anchor's ux and depth are the contact's current ones, not stored) and
// the entries' stored doubles. The table comes last so that one pass writes everything.
constexpr std::size_t CompactBound(std::size_t n) {
  return 1 + (n + 3) / 4 + (n + 1) / 2 + (2 * n + 1) * sizeof(double) + 1 +
         kMaxTable * (1 + 2 * sizeof(double));
}

std::size_t RawBytes(std::size_t n) { return 1 + n * (2 * sizeof(double) + 1 + kAnchorBytes); }

// Writes the compact encoding into out (room for CompactBound(n)); its length, or 0 when the
// anchors do not fit the table (the raw encoding then).
std::size_t WriteCompact(const PiecewiseLinearMemory& m, double ux, unsigned char* out) {
  const std::size_t n = m.vertex_count();
  const std::vector<double>& z = m.z();
  const std::vector<double>& u = m.u();
  const std::vector<std::uint8_t>& tags = m.tags();
  const std::vector<SegmentAnchor>& anchors = m.anchors();
  const double depth = m.depth();
  const SegmentAnchor* table[kMaxTable];
  std::size_t table_size = 0;
  const std::size_t tag_bytes = (n + 3) / 4, index_bytes = (n + 1) / 2;
  unsigned char* packed = out + 1;
  std::memset(packed, 0, tag_bytes + index_bytes);
  for (std::size_t i = 0; i < n; ++i) {
    packed[i / 4] |= static_cast<unsigned char>(tags[i] << (2 * (i % 4)));
    const SegmentAnchor& a = anchors[i];
    if (IsEmptyAnchor(a)) continue;
    std::size_t k = 0;
    while (k < table_size && !SameAnchor(*table[k], a)) ++k;
    if (k == table_size) {
      if (table_size == kMaxTable) return 0;
      table[table_size++] = &a;
    }
    packed[tag_bytes + i / 2] |= static_cast<unsigned char>((k + 1) << (4 * (i % 2)));
  }
  unsigned char format = kCompact;
  if (!SameBits(z.front(), 0.0)) format |= kFirstZStored;
  if (!SameBits(z.back(), depth)) format |= kLastZStored;
  if (!SameBits(u.back(), 0.0)) format |= kLastUStored;
  out[0] = format;
  Writer w(packed + tag_bytes + index_bytes);
  for (std::size_t i = 1; i + 1 < n; ++i) w.Double(z[i]);
  for (std::size_t i = 0; i + 1 < n; ++i) w.Double(u[i]);
  if (format & kFirstZStored) w.Double(z.front());
  if (format & kLastZStored) w.Double(z.back());
  if (format & kLastUStored) w.Double(u.back());
  w.Byte(static_cast<unsigned char>(table_size));
  for (std::size_t k = 0; k < table_size; ++k) {
    const SegmentAnchor& a = *table[k];
    const bool current_ux = SameBits(a.tangential_displacement, ux);
    const bool current_depth = SameBits(a.depth, depth);
    w.Byte(static_cast<unsigned char>(a.bound | (current_ux ? kCurrentUx : 0) |
                                      (current_depth ? kCurrentDepth : 0)));
    if (!current_ux) w.Double(a.tangential_displacement);
    if (!current_depth) w.Double(a.depth);
  }
  return static_cast<std::size_t>(w.at() - out);
}

void WriteRaw(const PiecewiseLinearMemory& m, unsigned char* out) {
  const std::size_t n = m.vertex_count();
  Writer w(out);
  w.Byte(kRaw);
  for (std::size_t i = 0; i < n; ++i) w.Double(m.z()[i]);
  for (std::size_t i = 0; i < n; ++i) w.Double(m.u()[i]);
  for (std::size_t i = 0; i < n; ++i) w.Byte(m.tags()[i]);
  for (std::size_t i = 0; i < n; ++i) WriteAnchor(w, m.anchors()[i]);
}

std::size_t GridBytes(const GridMemory& g) {
  return 1 + g.size() * (sizeof(double) + 1 + kAnchorBytes);
}

void WriteGrid(const GridMemory& g, unsigned char* out) {
  Writer w(out);
  w.Byte(kGrid);
  const std::size_t n = g.size();
  for (std::size_t j = 0; j < n; ++j) w.Double(g.u()[static_cast<Eigen::Index>(j)]);
  for (std::size_t j = 0; j < n; ++j) w.Byte(g.Tag(j));
  for (std::size_t j = 0; j < n; ++j) WriteAnchor(w, g.anchors()[j]);
}

// Heap blocks are sized in steps of this many bytes, so that a memory that grows and shrinks by
// a vertex in place keeps its block.
constexpr std::size_t kBlockGranule = 64;

}  // namespace

void PackedContacts::FreeRecords::operator()(Record* records) const { std::free(records); }

std::unique_ptr<PackedContacts::Record[], PackedContacts::FreeRecords>
PackedContacts::AllocateRecords(std::size_t n) {
  // A large array (a step of 10^6 contacts writes a new one of 128 MB) on transparent huge pages
  // where the kernel offers them on request: 512 times fewer page faults when the workers first
  // touch it. Small arrays on cache lines.
  constexpr std::size_t kHugePage = std::size_t{2} << 20;
  const std::size_t bytes = std::max<std::size_t>(n, 1) * sizeof(Record);
  const std::size_t alignment = bytes >= 4 * kHugePage ? kHugePage : 64;
  void* memory = std::aligned_alloc(alignment, (bytes + alignment - 1) / alignment * alignment);
  if (memory == nullptr) throw std::bad_alloc();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  if (alignment == kHugePage) (void)madvise(memory, bytes / kHugePage * kHugePage, MADV_HUGEPAGE);
#endif
  return std::unique_ptr<Record[], FreeRecords>(static_cast<Record*>(memory));  // trivial type
}

PackedContacts::PackedContacts(std::size_t n) : records_(AllocateRecords(n)), size_(n) {
  std::memset(static_cast<void*>(records_.get()), 0, n * sizeof(Record));  // empty records
}

PackedContacts PackedContacts::Unwritten(std::size_t n) {
  PackedContacts unwritten;
  unwritten.records_ = AllocateRecords(n);  // trivial: not initialized
  unwritten.size_ = n;
  return unwritten;
}

PackedContacts::PackedContacts(const PackedContacts& other) { CopyFrom(other); }

PackedContacts& PackedContacts::operator=(const PackedContacts& other) {
  if (this != &other) {
    FreeBlocks();
    CopyFrom(other);
  }
  return *this;
}

PackedContacts::PackedContacts(PackedContacts&& other) noexcept
    : records_(std::move(other.records_)),
      size_(std::exchange(other.size_, 0)),
      heap_bytes_(other.heap_bytes_.exchange(0)) {}

PackedContacts& PackedContacts::operator=(PackedContacts&& other) noexcept {
  if (this != &other) {
    FreeBlocks();
    records_ = std::move(other.records_);
    size_ = std::exchange(other.size_, 0);
    heap_bytes_.store(other.heap_bytes_.exchange(0));
  }
  return *this;
}

PackedContacts::~PackedContacts() { FreeBlocks(); }

void PackedContacts::CopyFrom(const PackedContacts& other) {
  size_ = other.size_;
  records_ = AllocateRecords(size_);  // every byte copied below
  heap_bytes_.store(0);
  if (size_ == 0) return;  // other may hold no array at all
  std::memcpy(static_cast<void*>(records_.get()), other.records_.get(), size_ * sizeof(Record));
  if (other.heap_bytes() == 0) return;  // no block to copy: no walk over the records
  std::size_t heap = 0;
  for (std::size_t i = 0; i < size_; ++i) {
    Record& r = records_[i];
    if (r.bytes <= kInlineBytes) continue;
    const std::uint32_t capacity = BlockCapacity(r);
    auto* block = static_cast<unsigned char*>(std::malloc(capacity));
    if (block == nullptr) throw std::bad_alloc();
    std::memcpy(block, Block(r), r.bytes);
    std::memcpy(r.data, &block, sizeof block);
    heap += capacity;
  }
  heap_bytes_.store(heap);
}

unsigned char* PackedContacts::Block(const Record& r) const {
  unsigned char* block;
  std::memcpy(&block, r.data, sizeof block);
  return block;
}

std::uint32_t PackedContacts::BlockCapacity(const Record& r) const {
  std::uint32_t capacity;
  std::memcpy(&capacity, r.data + sizeof(unsigned char*), sizeof capacity);
  return capacity;
}

void PackedContacts::FreeBlock(Record& r) {
  if (r.bytes <= kInlineBytes) return;
  heap_bytes_.fetch_sub(BlockCapacity(r), std::memory_order_relaxed);
  std::free(Block(r));
  r.bytes = 0;
}

void PackedContacts::FreeBlocks() {
  // Most interfaces have no block at all: no walk over millions of records then.
  for (std::size_t i = 0; i < size_ && heap_bytes_.load() > 0; ++i) FreeBlock(records_[i]);
}

unsigned char* PackedContacts::Reserve(Record& r, std::size_t bytes) {
  unsigned char* out = r.data;
  if (bytes > kInlineBytes) {
    if (r.bytes > kInlineBytes && BlockCapacity(r) >= bytes) {
      out = Block(r);
    } else {
      FreeBlock(r);
      const std::size_t capacity = (bytes + kBlockGranule - 1) / kBlockGranule * kBlockGranule;
      out = static_cast<unsigned char*>(std::malloc(capacity));
      if (out == nullptr) throw std::bad_alloc();
      const auto capacity32 = static_cast<std::uint32_t>(capacity);
      std::memcpy(r.data, &out, sizeof out);
      std::memcpy(r.data + sizeof out, &capacity32, sizeof capacity32);
      heap_bytes_.fetch_add(capacity, std::memory_order_relaxed);
    }
  } else {
    FreeBlock(r);
  }
  r.bytes = static_cast<std::uint32_t>(bytes);
  return out;
}

void PackedContacts::Put(std::size_t i, const Contact& contact, std::uint32_t config) {
  Record& r = records_[i];
  r.depth = contact.depth();
  r.ux = contact.tangential_displacement();
  r.dissipated = contact.dissipated_energy();
  r.last_dissipated = contact.last_step_dissipation();
  r.config = config;
  if (const GridMemory* grid = contact.grid_memory()) {
    r.vertices = 0;
    WriteGrid(*grid, Reserve(r, GridBytes(*grid)));
    return;
  }
  const PiecewiseLinearMemory& m = contact.memory();
  const std::size_t n = m.vertex_count();
  r.vertices = static_cast<std::uint32_t>(n);
  if (n < 2) {  // out of contact: nothing to encode (in contact there are at least 2)
    unsigned char* out = Reserve(r, n == 0 ? 0 : RawBytes(n));
    if (n > 0) WriteRaw(m, out);
    return;
  }
  // The compact encoding is written into a buffer first (its length is known at the end) and
  // copied: a few dozen bytes for the memories of a rough interface.
  constexpr std::size_t kStackVertices = 16;
  unsigned char stack[CompactBound(kStackVertices)];
  thread_local std::vector<unsigned char> large;
  unsigned char* buffer = stack;
  if (n > kStackVertices) {
    large.resize(CompactBound(n));
    buffer = large.data();
  }
  if (const std::size_t bytes = WriteCompact(m, r.ux, buffer); bytes > 0) {
    std::memcpy(Reserve(r, bytes), buffer, bytes);
  } else {
    WriteRaw(m, Reserve(r, RawBytes(n)));
  }
}

void PackedContacts::Get(std::size_t i, Contact* contact) const {
  const Record& r = records_[i];
  contact->ux_ = r.ux;
  contact->dissipated_ = r.dissipated;
  contact->last_dissipated_ = r.last_dissipated;
  Reader in(r.bytes > kInlineBytes ? Block(r) : r.data);
  if (auto* grid = std::get_if<GridMemory>(&contact->memory_)) {
    grid->depth_ = r.depth;
    const std::size_t n = grid->size();
    if (r.bytes == 0) {  // a fresh record
      grid->u_.setZero();
      std::fill(grid->tag_.begin(), grid->tag_.end(), std::uint8_t{kInside});
      std::fill(grid->anchor_.begin(), grid->anchor_.end(), SegmentAnchor{});
      return;
    }
    in.Byte();
    for (std::size_t j = 0; j < n; ++j) grid->u_[static_cast<Eigen::Index>(j)] = in.Double();
    for (std::size_t j = 0; j < n; ++j) grid->tag_[j] = in.Byte();
    for (std::size_t j = 0; j < n; ++j) grid->anchor_[j] = ReadAnchor(in);
    return;
  }
  PiecewiseLinearMemory& m = std::get<PiecewiseLinearMemory>(contact->memory_);
  m.depth_ = r.depth;
  const std::size_t n = r.vertices;
  m.z_.resize(n);
  m.u_.resize(n);
  m.tag_.resize(n);
  m.anchor_.resize(n);
  if (n == 0) return;
  const unsigned char format = in.Byte();
  if ((format & kKindMask) == kRaw) {
    for (std::size_t k = 0; k < n; ++k) m.z_[k] = in.Double();
    for (std::size_t k = 0; k < n; ++k) m.u_[k] = in.Double();
    for (std::size_t k = 0; k < n; ++k) m.tag_[k] = in.Byte();
    for (std::size_t k = 0; k < n; ++k) m.anchor_[k] = ReadAnchor(in);
    return;
  }
  const unsigned char* packed = in.at();
  const std::size_t tag_bytes = (n + 3) / 4, index_bytes = (n + 1) / 2;
  in.Skip(tag_bytes + index_bytes);
  double* z = m.z_.data();
  double* u = m.u_.data();
  for (std::size_t k = 1; k + 1 < n; ++k) z[k] = in.Double();
  for (std::size_t k = 0; k + 1 < n; ++k) u[k] = in.Double();
  z[0] = format & kFirstZStored ? in.Double() : 0.0;
  z[n - 1] = format & kLastZStored ? in.Double() : r.depth;
  u[n - 1] = format & kLastUStored ? in.Double() : 0.0;
  // [0]: the empty anchor; only the entries in use are built (this runs for every contact of
  // every step).
  alignas(SegmentAnchor) unsigned char storage[(kMaxTable + 1) * sizeof(SegmentAnchor)];
  auto* table = reinterpret_cast<SegmentAnchor*>(storage);
  const std::size_t table_size = in.Byte();
  new (&table[0]) SegmentAnchor{};
  for (std::size_t k = 1; k <= table_size; ++k) {
    const unsigned char kind = in.Byte();
    const double ux = kind & kCurrentUx ? r.ux : in.Double();
    const double depth = kind & kCurrentDepth ? r.depth : in.Double();
    new (&table[k]) SegmentAnchor{static_cast<BoundTag>(kind & kKindMask), ux, depth};
  }
  for (std::size_t k = 0; k < n; ++k) {
    m.tag_[k] = (packed[k / 4] >> (2 * (k % 4))) & 3;
    m.anchor_[k] = table[(packed[tag_bytes + k / 2] >> (4 * (k % 2))) & 15];
  }
}

std::uint32_t ConfigTable::Add(const ContactConfig& config, bool* added) {
  std::vector<std::uint32_t>& same_profile = entries_by_profile_[config.profile.get()];
  for (std::uint32_t k : same_profile) {
    if (SameSettings(settings_[entries_[k].settings], config)) {
      *added = false;
      return k;
    }
  }
  std::vector<std::uint32_t>& same_hash = settings_by_hash_[HashSettings(config)];
  const auto found = std::find_if(same_hash.begin(), same_hash.end(), [&](std::uint32_t k) {
    return SameSettings(settings_[k], config);
  });
  std::uint32_t settings = 0;
  if (found != same_hash.end()) {
    settings = *found;
  } else {
    settings = static_cast<std::uint32_t>(settings_.size());
    settings_.push_back(config);
    settings_.back().profile = nullptr;
    same_hash.push_back(settings);
  }
  // Consecutive profiles of one allocation (MakeSpheres) share its owning pointer.
  const bool same_owner = !owners_.empty() && !owners_.back().owner_before(config.profile) &&
                          !config.profile.owner_before(owners_.back());
  if (!same_owner) owners_.push_back(config.profile);
  if (same_profile.empty() && config.profile != nullptr) {
    ++profile_count_;
    profile_bytes_ += config.profile->MemoryBytes();
  }
  const auto k = static_cast<std::uint32_t>(entries_.size());
  entries_.push_back(
      {config.profile.get(), settings, static_cast<std::uint32_t>(owners_.size() - 1)});
  same_profile.push_back(k);
  *added = true;
  return k;
}

void ConfigTable::FinishAdding() {
  settings_by_hash_ = {};
  entries_by_profile_ = {};
  settings_.shrink_to_fit();
  entries_.shrink_to_fit();
  owners_.shrink_to_fit();
}

ContactConfig ConfigTable::Config(std::uint32_t k) const {
  ContactConfig config = settings(k);
  config.profile = ProfilePtr(owners_[entries_[k].owner], entries_[k].profile);
  return config;
}

std::size_t ConfigTable::MemoryBytes() const {
  // An owning pointer's allocation also holds a control block (and the allocator's header).
  constexpr std::size_t kControlBlockBytes = 32;
  return entries_.capacity() * sizeof(Entry) + settings_.capacity() * sizeof(ContactConfig) +
         owners_.capacity() * sizeof(ProfilePtr) + owners_.size() * kControlBlockBytes +
         profile_bytes_;
}

void ContactCursor::Bind(std::uint32_t config) {
  if (contact_ && bound_ == config) return;
  const ContactConfig& settings = configs_->settings(config);
  if (contact_ && contact_->config_.method == Method::kExact && settings.method == Method::kExact) {
    // The memory's vectors keep their capacity; summits of one surface share their settings.
    if (configs_->settings_index(bound_) != configs_->settings_index(config)) {
      contact_->config_ = settings;
    }
    contact_->config_.profile = configs_->BorrowedProfile(config);
  } else {
    ContactConfig bound = settings;
    bound.profile = configs_->BorrowedProfile(config);
    contact_.emplace(Contact(std::move(bound)));
  }
  bound_ = config;
}

Contact ContactCursor::Copy(const PackedContacts& store, std::size_t i) {
  Contact copy = Load(store, i);
  copy.config_ = configs_->Config(store.config_index(i));
  return copy;
}

Contact& ContactCursor::Load(const PackedContacts& store, std::size_t i) {
  Bind(store.config_index(i));
  store.Get(i, &*contact_);
  return *contact_;
}

Contact& ContactCursor::Fresh(std::uint32_t config) {
  Bind(config);
  static const PackedContacts kEmpty(1);  // zeroed: an empty record
  // A fresh record is out of contact with no memory; its config index is not read by Get.
  kEmpty.Get(0, &*contact_);
  return *contact_;
}

}  // namespace mdr
