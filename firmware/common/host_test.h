// A tiny assert-based test runner for the firmware cores compiled on the host with g++.
// Each TEST registers itself; run_all_tests() prints the first failures of each test and the closing
// line "N passed, N failed" that the pytest wrapper reads.
#ifndef HOST_TEST_H
#define HOST_TEST_H

#include <cmath>
#include <cstdio>

struct host_test_case {
    const char* name;
    void (*body)();
    host_test_case* next;
};

inline host_test_case*& host_test_registry() {
    static host_test_case* head = nullptr;
    return head;
}

inline int& host_test_failures_in_case() {
    static int failures = 0;
    return failures;
}

struct host_test_registrar {
    host_test_case item;
    host_test_registrar(const char* name, void (*body)()) : item{name, body, nullptr} {
        host_test_case** tail = &host_test_registry();
        while (*tail) tail = &(*tail)->next;  // keep declaration order for readable output
        *tail = &item;
    }
};

#define TEST(name)                                                   \
    static void name();                                              \
    static host_test_registrar name##_registrar(#name, name);        \
    static void name()

#define CHECK(cond)                                                                  \
    do {                                                                             \
        if (!(cond)) {                                                               \
            if (++host_test_failures_in_case() <= 3)                                 \
                std::printf("  %s:%d: CHECK(%s) failed\n", __FILE__, __LINE__, #cond); \
        }                                                                            \
    } while (0)

#define CHECK_EQ(a, b)                                                                     \
    do {                                                                                   \
        long long check_a_ = (long long)(a), check_b_ = (long long)(b);                    \
        if (check_a_ != check_b_ && ++host_test_failures_in_case() <= 3) {                 \
            std::printf("  %s:%d: CHECK_EQ(%s, %s) failed: %lld != %lld\n", __FILE__,      \
                        __LINE__, #a, #b, check_a_, check_b_);                             \
        }                                                                                  \
    } while (0)

#define CHECK_NEAR(a, b, tol)                                                              \
    do {                                                                                   \
        double check_a_ = (double)(a), check_b_ = (double)(b);                             \
        if (!(std::fabs(check_a_ - check_b_) <= (tol)) &&                                  \
            ++host_test_failures_in_case() <= 3) {                                         \
            std::printf("  %s:%d: CHECK_NEAR(%s, %s) failed: %.6g vs %.6g\n", __FILE__,    \
                        __LINE__, #a, #b, check_a_, check_b_);                             \
        }                                                                                  \
    } while (0)

#define CHECK_STR(a, b) CHECK(std::string(a) == std::string(b))

inline int run_all_tests() {
    int passed = 0, failed = 0;
    for (host_test_case* t = host_test_registry(); t; t = t->next) {
        host_test_failures_in_case() = 0;
        t->body();
        if (host_test_failures_in_case() == 0) {
            ++passed;
        } else {
            ++failed;
            std::printf("FAILED %s\n", t->name);
        }
    }
    std::printf("%d passed, %d failed\n", passed, failed);
    return failed == 0 ? 0 : 1;
}

#endif
