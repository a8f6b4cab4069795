#include "harness/live/process_output.h"

#include <fstream>
#include <sstream>

namespace lockroll::harness {

namespace fs = std::filesystem;

std::string num(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
}

std::string read_text(const fs::path& p) {
    std::ifstream f(p);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
}

std::vector<std::vector<std::string>> read_csv_rows(const fs::path& p) {
    std::vector<std::vector<std::string>> rows;
    std::ifstream f(p);
    std::string line;
    bool header = true;
    while (std::getline(f, line)) {
        if (header) {
            header = false;
            continue;
        }
        std::vector<std::string> cells;
        std::stringstream s(line);
        std::string cell;
        while (std::getline(s, cell, ',')) cells.push_back(cell);
        rows.push_back(std::move(cells));
    }
    return rows;
}

std::string failure_line(const fs::path& stderr_log) {
    std::ifstream f(stderr_log);
    std::string line, sanitizer, own, logged;
    while (std::getline(f, line)) {
        if (sanitizer.empty() && (line.find("ERROR: ") != std::string::npos && line.find("Sanitizer") != std::string::npos))
            sanitizer = line;
        else if (sanitizer.empty() && line.find(": runtime error: ") != std::string::npos)
            sanitizer = line;
        else if (line.rfind("lockroll: ", 0) == 0)
            own = line;
        else if (line.find("[error]") != std::string::npos || line.find("[critical]") != std::string::npos)
            logged = line;
    }
    std::string why = !sanitizer.empty() ? sanitizer : !own.empty() ? own : logged;
    if (why.size() > 300) why = why.substr(0, 297) + "...";
    return why;
}

}  // namespace lockroll::harness
