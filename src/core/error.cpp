#include "src/core/error.hpp"

#include <exception>
#include <mutex>
#include <utility>

namespace amhv {

namespace {

struct Reading {
    std::mutex mutex;
    std::string file, left_by_exception;
};

Reading& reading() {
    static Reading r;
    return r;
}

}  // namespace

ReadingFile::ReadingFile(std::string path) : exceptions_(std::uncaught_exceptions()) {
    std::lock_guard<std::mutex> hold(reading().mutex);
    previous_ = std::exchange(reading().file, std::move(path));
}

ReadingFile::~ReadingFile() {
    std::lock_guard<std::mutex> hold(reading().mutex);
    if (std::uncaught_exceptions() > exceptions_ && reading().left_by_exception.empty()) reading().left_by_exception = reading().file;
    reading().file = std::move(previous_);
}

std::string ReadingFile::current() {
    std::lock_guard<std::mutex> hold(reading().mutex);
    return reading().file.empty() ? reading().left_by_exception : reading().file;
}

}  // namespace amhv
