#include "scanbench/harness/config/plugins.h"

#include <dlfcn.h>
#include <elf.h>
#include <fmt/format.h>
#include <link.h>
#include <openssl/evp.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>

#include "scanbench/core/errors.h"
#include "scanbench/plugin.h"

namespace scanbench::harness {

namespace fs = std::filesystem;

namespace {

std::vector<LoadedPlugin>& plugins() {
  static std::vector<LoadedPlugin> p;
  return p;
}

// Collects a plugin's entries; they reach the registries only once all are checked.
class Collector final : public PluginRegistrar {
 public:
  void add(algorithms::AlgorithmRegistry::Entry e) override { algorithms_.push_back(std::move(e)); }
  void add(metrics::MetricRegistry::Entry e) override { metrics_.push_back(std::move(e)); }
  std::vector<algorithms::AlgorithmRegistry::Entry> algorithms_;
  std::vector<metrics::MetricRegistry::Entry> metrics_;
};

// Who registered `name` already: "built in", "by plugin <path>", or "" when nobody did.
std::string owner(std::string_view kind, std::string_view name) {
  const bool known = kind == "algorithm" ? algorithms::registry().find(name) != nullptr
                                         : metrics::registry().find(name) != nullptr;
  if (!known) return "";
  if (const LoadedPlugin* p = plugin_of(kind, name)) return "by plugin " + p->path.string();
  return "built in";
}

// Refuses the collected entries (Error naming the file) unless all can be added.
void check_entries(const fs::path& file, const Collector& c) {
  std::set<std::string> seen;
  auto check_name = [&](std::string_view kind, const std::string& name) {
    if (name.empty())
      throw Error(fmt::format("plugin {}: an {} with an empty name", file.string(), kind));
    const std::string who = owner(kind, name);
    if (!who.empty()) {
      throw Error(fmt::format("plugin {}: {} '{}' is already registered ({})", file.string(), kind,
                              name, who));
    }
    if (!seen.insert(std::string(kind) + ":" + name).second) {
      throw Error(fmt::format("plugin {}: registers {} '{}' twice", file.string(), kind, name));
    }
  };
  for (const auto& e : c.algorithms_) {
    check_name("algorithm", e.name);
    if (!e.fn.run)
      throw Error(fmt::format("plugin {}: algorithm '{}' has no function", file.string(), e.name));
  }
  for (const auto& e : c.metrics_) {
    check_name("metric", e.name);
    if (!e.fn.run)
      throw Error(fmt::format("plugin {}: metric '{}' has no function", file.string(), e.name));
    if (e.fn.keys.empty()) {
      throw Error(fmt::format("plugin {}: metric '{}' declares no keys", file.string(), e.name));
    }
    // One direction per key across every metric (tables, compare and claims read it by key).
    for (const auto& k : e.fn.keys) {
      const auto d = metrics::key_direction(k.key);
      if (d && *d != k.better) {
        throw Error(
            fmt::format("plugin {}: metric '{}' declares key '{}' {} is better, but the "
                        "registered metrics declare it {}",
                        file.string(), e.name, k.key, metrics::better_name(k.better),
                        metrics::better_name(*d)));
      }
    }
  }
}

using Handle = std::unique_ptr<void, int (*)(void*)>;

/// Refuses a file that dlopen could not map whole (IoError, one line). The loader maps each
/// segment of the file's program headers; a segment that ends beyond the end of the file (a
/// truncated copy, a download cut short) is mapped all the same, and its first touch beyond
/// the end raises SIGBUS inside dlopen. So before dlopen: the ELF header (magic, this build's
/// class and byte order, a shared object), the program header table and every segment's file
/// bytes are checked against the file's size. No library reads ELF headers without also mapping
/// the file, hence <elf.h> by hand.
void check_elf_file(const fs::path& file) {
  using Ehdr = ElfW(Ehdr);
  using Phdr = ElfW(Phdr);
  std::ifstream in(file, std::ios::binary);
  std::error_code ec;
  const std::uint64_t size = fs::file_size(file, ec);
  if (!in || ec) {
    throw IoError(fmt::format("plugin {}: cannot read: {}", file.string(),
                              ec ? ec.message() : std::strerror(errno)));
  }
  const auto incomplete = [&](const std::string& what, std::uint64_t end) {
    throw IoError(fmt::format(
        "plugin {}: not a complete shared library ({} ends at byte {}, beyond the file's {} bytes)",
        file.string(), what, end, size));
  };
  Ehdr eh{};
  if (size < sizeof eh) {
    if (size >= SELFMAG) {
      char magic[SELFMAG];
      if (in.read(magic, SELFMAG) && std::memcmp(magic, ELFMAG, SELFMAG) == 0) {
        incomplete("the ELF header", sizeof eh);
      }
    }
    throw IoError(fmt::format("plugin {}: not a shared library (no ELF header)", file.string()));
  }
  in.read(reinterpret_cast<char*>(&eh), sizeof eh);
  if (!in || std::memcmp(eh.e_ident, ELFMAG, SELFMAG) != 0) {
    throw IoError(fmt::format("plugin {}: not a shared library (no ELF header)", file.string()));
  }
  constexpr unsigned char kClass = sizeof(void*) == 8 ? ELFCLASS64 : ELFCLASS32;
  constexpr unsigned char kData =
      __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__ ? ELFDATA2LSB : ELFDATA2MSB;
  if (eh.e_ident[EI_CLASS] != kClass || eh.e_ident[EI_DATA] != kData) {
    throw IoError(fmt::format("plugin {}: an ELF file for another kind of machine ({}-bit, {})",
                              file.string(), eh.e_ident[EI_CLASS] == ELFCLASS64 ? 64 : 32,
                              eh.e_ident[EI_DATA] == ELFDATA2LSB ? "little-endian" : "big-endian"));
  }
  if (eh.e_type != ET_DYN) {
    throw IoError(fmt::format("plugin {}: not a shared library (ELF type {}, expected {})",
                              file.string(), eh.e_type, ET_DYN));
  }
  if (eh.e_phnum == 0 || eh.e_phentsize != sizeof(Phdr)) {
    throw IoError(fmt::format("plugin {}: not a shared library ({} program headers of {} bytes)",
                              file.string(), eh.e_phnum, eh.e_phentsize));
  }
  // Offsets come from the file: compared as differences, so no sum can wrap around.
  const std::uint64_t table = std::uint64_t{eh.e_phnum} * sizeof(Phdr);
  if (eh.e_phoff > size || table > size - eh.e_phoff) {
    incomplete("the program header table",
               eh.e_phoff > std::numeric_limits<std::uint64_t>::max() - table ? eh.e_phoff
                                                                              : eh.e_phoff + table);
  }
  std::vector<Phdr> ph(eh.e_phnum);
  in.seekg(static_cast<std::streamoff>(eh.e_phoff));
  in.read(reinterpret_cast<char*>(ph.data()), static_cast<std::streamsize>(table));
  if (!in) throw IoError(fmt::format("plugin {}: cannot read its program headers", file.string()));
  for (std::size_t i = 0; i < ph.size(); ++i) {
    if (ph[i].p_offset > size || ph[i].p_filesz > size - ph[i].p_offset) {
      const std::uint64_t end =
          ph[i].p_offset > std::numeric_limits<std::uint64_t>::max() - ph[i].p_filesz
              ? ph[i].p_offset
              : ph[i].p_offset + ph[i].p_filesz;
      incomplete(fmt::format("program header {}", i), end);
    }
  }
}

/// The listeners of ProgressListener, by context; the host's handler dispatches to them.
struct Listeners {
  std::mutex mutex;
  std::map<const RunContext*, std::function<void(const std::string&, double)>> by_ctx;
};
Listeners& listeners() {
  static Listeners l;
  return l;
}

void dispatch_progress(const RunContext& ctx, const char* what, double fraction) {
  Listeners& l = listeners();
  const std::lock_guard<std::mutex> lock(l.mutex);
  const auto it = l.by_ctx.find(&ctx);
  if (it != l.by_ctx.end()) it->second(what ? what : "", fraction);
}

void* symbol(void* handle, const fs::path& file, const char* name) {
  dlerror();
  void* s = dlsym(handle, name);
  if (s == nullptr) {
    throw Error(
        fmt::format("plugin {}: no symbol {} (not a scanbench plugin? define its registration with "
                    "SCANBENCH_PLUGIN, scanbench/plugin.h)",
                    file.string(), name));
  }
  return s;
}

}  // namespace

Json LoadedPlugin::to_json() const {
  return Json{{"path", path.string()},
              {"sha256", sha256},
              {"algorithms", algorithms},
              {"metrics", metrics}};
}

std::string file_sha256(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw IoError(fmt::format("{}: cannot read", file.string()));
  std::unique_ptr<EVP_MD_CTX, void (*)(EVP_MD_CTX*)> ctx(EVP_MD_CTX_new(), EVP_MD_CTX_free);
  if (!ctx || EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr) != 1) {
    throw Error(fmt::format("{}: SHA-256: OpenSSL digest unavailable", file.string()));
  }
  std::vector<char> buf(1 << 16);
  while (in) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    if (in.gcount() > 0)
      EVP_DigestUpdate(ctx.get(), buf.data(), static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) throw IoError(fmt::format("{}: read error", file.string()));
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  EVP_DigestFinal_ex(ctx.get(), md, &n);
  std::string hex;
  for (unsigned int i = 0; i < n; ++i)
    hex += fmt::format("{:02x}", md[i]);
  return hex;
}

const LoadedPlugin& load_plugin(const fs::path& file, const std::string& origin) {
  const fs::path path = fs::absolute(file).lexically_normal();
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    throw IoError(fmt::format("plugin {}: no such file", path.string()));
  }
  const fs::path canonical = fs::canonical(path);
  for (const auto& p : plugins())
    if (fs::canonical(p.path, ec) == canonical) return p;
  LoadedPlugin lp;
  lp.path = path;
  lp.origin = origin;
  lp.sha256 = file_sha256(path);
  check_elf_file(path);

  // RTLD_NOW: an unresolved symbol is this error, not a crash in the middle of a job.
  dlerror();
  Handle handle(dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL), dlclose);
  if (!handle) {
    const char* why = dlerror();
    throw Error(fmt::format("plugin {}: cannot load: {}", path.string(), why ? why : "unknown"));
  }
  const auto abi = reinterpret_cast<PluginAbiFn>(symbol(handle.get(), path, kPluginAbiSymbol));
  const auto reg =
      reinterpret_cast<PluginRegisterFn>(symbol(handle.get(), path, kPluginRegisterSymbol));
  if (const int v = abi(); v != SCANBENCH_ABI_VERSION) {
    throw Error(fmt::format(
        "plugin {}: built against scanbench ABI version {}, this scanbench has {} (rebuild it "
        "against this scanbench's installed package)",
        path.string(), v, SCANBENCH_ABI_VERSION));
  }
  const auto align = reinterpret_cast<PluginAbiFn>(symbol(handle.get(), path, kPluginAlignSymbol));
  if (const int a = align(); a != EIGEN_MAX_ALIGN_BYTES) {
    throw Error(fmt::format(
        "plugin {}: compiled with Eigen alignment {} bytes, this scanbench with {} (compile it "
        "for the same instruction set; scanbench::core's usage requirements give the flags)",
        path.string(), a, EIGEN_MAX_ALIGN_BYTES));
  }
  // Optional (plugins built before it lack it): the plugin's report_progress calls reach the
  // host's listeners.
  dlerror();
  if (void* sp = dlsym(handle.get(), kPluginProgressSymbol))
    reinterpret_cast<PluginSetProgressFn>(sp)(&dispatch_progress);
  // From here the plugin's code may be referenced (its entries' functions, its statics): the
  // library stays loaded for the life of the process, also when it is refused.
  void* h = handle.release();
  (void)h;
  Collector c;
  try {
    reg(c);
  } catch (const std::exception& e) {
    throw Error(fmt::format("plugin {}: its registration threw: {}", path.string(), e.what()));
  } catch (...) {
    throw Error(
        fmt::format("plugin {}: its registration threw a non-standard exception", path.string()));
  }
  check_entries(path, c);
  for (auto& e : c.algorithms_) {
    lp.algorithms.push_back(e.name);
    algorithms::add_plugin_entry(std::move(e));
  }
  for (auto& e : c.metrics_) {
    lp.metrics.push_back(e.name);
    metrics::add_plugin_entry(std::move(e));
  }
  plugins().push_back(std::move(lp));
  return plugins().back();
}

void load_plugins_from_env() {
  const char* env = std::getenv("SCANBENCH_PLUGIN_PATH");
  if (env == nullptr) return;
  const std::string list = env;
  std::size_t start = 0;
  while (start <= list.size()) {
    const std::size_t end = std::min(list.find(':', start), list.size());
    const std::string item = list.substr(start, end - start);
    start = end + 1;
    if (item.empty()) continue;
    std::error_code ec;
    if (fs::is_directory(item, ec)) {
      std::vector<fs::path> files;
      for (const auto& d : fs::directory_iterator(item, ec))
        if (d.path().extension() == ".so" && d.is_regular_file(ec)) files.push_back(d.path());
      std::sort(files.begin(), files.end());
      for (const auto& f : files)
        load_plugin(f, "SCANBENCH_PLUGIN_PATH");
    } else if (fs::exists(item, ec)) {
      load_plugin(item, "SCANBENCH_PLUGIN_PATH");
    } else {
      throw IoError(fmt::format("SCANBENCH_PLUGIN_PATH: {}: no such file or folder", item));
    }
  }
}

void load_config_plugins(const Json& config, const fs::path& config_file) {
  if (!config.is_object() || !config.contains("plugins")) return;
  const Json& list = config["plugins"];
  if (!list.is_array()) {
    throw ParamError(
        fmt::format("{}: /plugins: expected a list of plugin files", config_file.string()));
  }
  const fs::path dir = fs::absolute(config_file).parent_path();
  for (std::size_t i = 0; i < list.size(); ++i) {
    if (!list[i].is_string() || list[i].get<std::string>().empty()) {
      throw ParamError(fmt::format("{}: /plugins/{}: expected a plugin file path, got {}",
                                   config_file.string(), i, list[i].dump()));
    }
    const fs::path p = list[i].get<std::string>();
    load_plugin(p.is_relative() ? dir / p : p, config_file.string());
  }
}

void load_spec_plugins(const Json& list) {
  if (!list.is_array()) throw IoError("job spec: /plugins: expected a list");
  for (const auto& j : list) {
    if (!j.is_object() || !j.value("path", Json()).is_string() ||
        !j.value("sha256", Json()).is_string()) {
      throw IoError("job spec: /plugins: expected {\"path\", \"sha256\"} strings, got " +
                    j.dump().substr(0, 80));
    }
    const LoadedPlugin& p = load_plugin(j["path"].get<std::string>(), "job spec");
    const std::string want = j["sha256"].get<std::string>();
    if (p.sha256 != want) {
      throw Error(
          fmt::format("plugin {}: the file changed since the run started (sha256 {} then, {} now)",
                      p.path.string(), want, p.sha256));
    }
  }
}

const std::vector<LoadedPlugin>& loaded_plugins() {
  return plugins();
}

Json plugins_json() {
  Json a = Json::array();
  for (const auto& p : plugins())
    a.push_back(p.to_json());
  return a;
}

const LoadedPlugin* plugin_of(std::string_view kind, std::string_view name) {
  for (const auto& p : plugins()) {
    const auto& names = kind == "algorithm" ? p.algorithms : p.metrics;
    if (std::find(names.begin(), names.end(), name) != names.end()) return &p;
  }
  return nullptr;
}

void mark_source(Json& entry, std::string_view kind) {
  const LoadedPlugin* p = plugin_of(kind, entry.value("name", std::string()));
  entry["source"] = p ? "plugin" : "builtin";
  if (p) entry["plugin"] = {{"path", p->path.string()}, {"sha256", p->sha256}};
}

}  // namespace scanbench::harness

namespace scanbench {

ProgressListener::ProgressListener(const RunContext& ctx,
                                   std::function<void(const std::string&, double)> on)
    : ctx_(&ctx) {
  harness::Listeners& l = harness::listeners();
  const std::lock_guard<std::mutex> lock(l.mutex);
  l.by_ctx[ctx_] = std::move(on);
  detail::progress_fn() = &harness::dispatch_progress;  // the host's own steps
}

ProgressListener::~ProgressListener() {
  harness::Listeners& l = harness::listeners();
  const std::lock_guard<std::mutex> lock(l.mutex);
  l.by_ctx.erase(ctx_);
}

}  // namespace scanbench
