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

}  // namespace lockroll::harness
