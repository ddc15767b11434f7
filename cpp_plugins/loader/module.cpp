// motivml._cpp_plugins: C++ feature plugins for the Python runtime, through ROS class_loader.
//
// A Library is one shared library, loaded eagerly (class_loader::ClassLoader, not on
// demand): a load failure throws here, at once. It counts its loads and its live instances,
// refuses to unload while an instance lives, and unloads for real (dlclose) when asked
// afterwards. Each Instance keeps its Library alive (pybind11 keep_alive), so a library is
// never closed under a live object. These calls run without the GIL: the live count is an
// atomic shared by the library and its instances (an instance may be released after its
// library object is gone), and creating and unloading hold the library's mutex, as
// class_loader guards its own counts.
#include <algorithm>
#include <atomic>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include <class_loader/class_loader.hpp>
#include <pybind11/functional.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <motivml/feature.hpp>

namespace py = pybind11;

namespace {

class PySpaces : public motivml::Spaces {
 public:
  std::vector<double> read(const std::string& space) override {
    PYBIND11_OVERRIDE_PURE(std::vector<double>, motivml::Spaces, read, space);
  }
  void write(const std::string& space, const std::vector<double>& value) override {
    PYBIND11_OVERRIDE_PURE(void, motivml::Spaces, write, space, value);
  }
};

class Library;

class Instance {
 public:
  Instance(std::shared_ptr<motivml::Feature> plugin, std::shared_ptr<std::atomic<int>> live)
      : plugin_(std::move(plugin)), live_(std::move(live)) {
    ++*live_;
  }
  Instance(const Instance&) = delete;
  Instance& operator=(const Instance&) = delete;
  ~Instance() { release(); }

  void start() { get().start(); }
  void step(double time, motivml::Spaces& spaces) { get().step(time, spaces); }
  void stop() { get().stop(); }
  std::string status() const { return plugin_ ? plugin_->status() : std::string("released"); }
  // Destroy the C++ object now (the Library may then unload).
  void release() {
    if (plugin_) {
      plugin_.reset();
      --*live_;
    }
  }

 private:
  motivml::Feature& get() {
    if (!plugin_) throw std::runtime_error("this plugin instance was released");
    return *plugin_;
  }
  std::shared_ptr<motivml::Feature> plugin_;
  std::shared_ptr<std::atomic<int>> live_;
};

class Library {
 public:
  explicit Library(const std::string& path)
      : path_(path), loader_(std::make_unique<class_loader::ClassLoader>(path, false)), loads_(1) {}
  Library(const Library&) = delete;
  Library& operator=(const Library&) = delete;
  ~Library() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (*live_ == 0 && loads_ > 0) unload_locked();
  }

  std::vector<std::string> classes() const { return loader_->getAvailableClasses<motivml::Feature>(); }

  std::unique_ptr<Instance> create(const std::string& name) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (loads_ == 0) {
      throw std::runtime_error("library " + path_ + " was unloaded");
    }
    auto declared = classes();
    if (std::find(declared.begin(), declared.end(), name) == declared.end()) {
      std::ostringstream message;
      message << "library " << path_ << " declares no class " << name << " (it declares: ";
      for (size_t i = 0; i < declared.size(); ++i) message << (i ? ", " : "") << declared[i];
      message << (declared.empty() ? "nothing" : "") << ")";
      throw std::runtime_error(message.str());
    }
    return std::make_unique<Instance>(loader_->createInstance<motivml::Feature>(name), live_);
  }

  // Give back this loader's loads; refused while an instance lives. The library is really
  // closed when no other loader in the process holds it (class_loader counts per path).
  // Returns whether it is still mapped because another loader holds it.
  bool unload() {
    std::lock_guard<std::mutex> lock(mutex_);
    return unload_locked();
  }

  bool loaded() const { return loads_ > 0; }
  int live() const { return *live_; }
  int loads() const { return loads_; }
  const std::string& path() const { return path_; }

 private:
  bool unload_locked() {
    const int live = *live_;
    if (live > 0) {
      throw std::runtime_error(std::to_string(live) + " instance(s) of " + path_ + " still live: not unloading");
    }
    for (; loads_ > 0; --loads_) {
      loader_->unloadLibrary();
    }
    return loader_->isLibraryLoadedByAnyClassloader();
  }

  std::string path_;
  std::unique_ptr<class_loader::ClassLoader> loader_;
  std::mutex mutex_;
  int loads_ = 0;
  std::shared_ptr<std::atomic<int>> live_ = std::make_shared<std::atomic<int>>(0);
};

}  // namespace

PYBIND11_MODULE(_cpp_plugins, m) {
  m.doc() = "C++ feature plugins through ROS class_loader (see motivml/plugins/cpp.py)";
  auto load_error = py::register_exception<class_loader::ClassLoaderException>(m, "LoadError", PyExc_RuntimeError);
  (void)load_error;
  py::class_<motivml::Spaces, PySpaces>(m, "Spaces")
      .def(py::init<>())
      .def("read", &motivml::Spaces::read)
      .def("write", &motivml::Spaces::write);
  py::class_<Instance>(m, "Instance")
      // start and stop may take long (devices, files): the control loop runs meanwhile
      .def("start", &Instance::start, py::call_guard<py::gil_scoped_release>())
      .def("step", &Instance::step)
      .def("stop", &Instance::stop, py::call_guard<py::gil_scoped_release>())
      .def("status", &Instance::status)
      .def("release", &Instance::release, py::call_guard<py::gil_scoped_release>());
  py::class_<Library>(m, "Library")
      // dlopen, dlclose and constructors need no Python: let the control loop run meanwhile.
      .def(py::init<const std::string&>(), py::call_guard<py::gil_scoped_release>())
      .def("classes", &Library::classes)
      .def("create", &Library::create, py::keep_alive<0, 1>(), py::call_guard<py::gil_scoped_release>())
      .def("unload", &Library::unload, py::call_guard<py::gil_scoped_release>())
      .def_property_readonly("loaded", &Library::loaded)
      .def_property_readonly("live", &Library::live)
      .def_property_readonly("loads", &Library::loads)
      .def_property_readonly("path", &Library::path);
}
