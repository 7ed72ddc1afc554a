// cases.mjs -- how every browser test reports: check(name, fn) runs one case
// and prints "PASS name" or "FAIL name: why" (tests/run.sh counts those
// lines).  A case passes when fn returns true or nothing, and fails with
// whatever else it returns or throws.  CASES=regex (in the environment)
// runs only the cases it matches, and the one named `always`, which opens
// the page the others need; later cases may need the state earlier ones
// leave.
export function cases(always) {
  const only = process.env.CASES ? new RegExp(process.env.CASES) : null;
  let failures = 0;
  const pass = (name) => console.log(`PASS ${name}`);
  const fail = (name, why) => {
    failures++;
    console.log(`FAIL ${name}: ${String(why).replace(/\s+/g, " ").slice(0, 500)}`);
  };
  async function check(name, fn) {
    if (only && name !== always && !only.test(name)) return;
    try {
      const r = await fn();
      if (r === true || r === undefined) pass(name);
      else fail(name, r);
    } catch (e) {
      fail(name, e && e.message ? e.message : e);
    }
  }
  return { pass, fail, check, failed: () => failures };
}
