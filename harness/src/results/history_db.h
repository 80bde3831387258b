#pragma once
// Private to the harness: a thin RAII layer over SQLite's C API (Debian's libsqlite3) for the
// history database (history.h). Every failure is an IoError naming the database file.
#include <cstdint>
#include <filesystem>
#include <string>

struct sqlite3;
struct sqlite3_stmt;

namespace scanbench::harness {

/// An open history database at the current schema. `create`: make the file (and the schema)
/// when missing; else a missing file is an IoError. Refuses (IoError, nothing written) a file
/// that is not a SQLite database and a schema newer than kHistorySchema.
class Db {
 public:
  Db(const std::filesystem::path& file, bool create);
  ~Db();
  Db(const Db&) = delete;
  Db& operator=(const Db&) = delete;

  sqlite3* handle() const { return db_; }
  const std::filesystem::path& file() const { return file_; }
  void exec(const std::string& sql);
  std::int64_t last_id() const;
  [[noreturn]] void fail(const std::string& what) const;

 private:
  void migrate(bool create);
  sqlite3* db_ = nullptr;
  std::filesystem::path file_;
};

/// BEGIN IMMEDIATE (takes the write lock now, waiting up to the busy timeout); rolls back unless
/// committed.
class Transaction {
 public:
  explicit Transaction(Db& db);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void commit();

 private:
  Db& db_;
  bool done_ = false;
};

/// A prepared statement; parameters are 1-based, columns 0-based.
class Stmt {
 public:
  Stmt(Db& db, const std::string& sql);
  ~Stmt();
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  Stmt& bind(int i, const std::string& v);
  Stmt& bind(int i, std::int64_t v);
  Stmt& bind(int i, double v);  ///< NaN and infinities as NULL
  Stmt& bind_null(int i);
  /// Next row: true while there is one.
  bool step();
  /// Executes a statement without result rows, then resets it for new bindings.
  void run();
  /// The first column of the first row (0 when there is none), then resets.
  std::int64_t step_int();
  std::string text(int col) const;
  double real(int col) const;  ///< NaN for NULL
  std::int64_t integer(int col) const;

 private:
  Db& db_;
  sqlite3_stmt* s_ = nullptr;
};

}  // namespace scanbench::harness
