import { useState, type FormEvent } from 'react';
import { Button } from '@/components/ui/Button';
import { login } from '../api/auth';

/** Shown when the brain answers 401 on /api/auth/me (deployments with operator login). */
export function LoginPage({ onSignedIn }: { onSignedIn: () => void }) {
  const [username, setUsername] = useState('admin');
  const [password, setPassword] = useState('');
  const [error, setError] = useState<string | null>(null);
  const [busy, setBusy] = useState(false);
  const submit = async (event: FormEvent) => {
    event.preventDefault();
    setBusy(true);
    setError(null);
    try {
      await login(username, password);
      onSignedIn();
    } catch (err) {
      setError(err instanceof Error ? err.message : String(err));
    } finally {
      setBusy(false);
    }
  };
  return (
    <main className="flex h-full items-center justify-center p-4">
      <form onSubmit={submit} aria-label="Sign in" className="flex w-80 flex-col gap-3 rounded-lg border border-line bg-surface p-5">
        <h1 className="text-base font-semibold">Robot operator — sign in</h1>
        <label className="flex flex-col gap-1 text-sm">
          User
          <input value={username} onChange={(e) => setUsername(e.target.value)} autoComplete="username"
            className="rounded-md border border-line bg-canvas px-3 py-2" />
        </label>
        <label className="flex flex-col gap-1 text-sm">
          Password
          <input type="password" value={password} onChange={(e) => setPassword(e.target.value)} autoComplete="current-password"
            className="rounded-md border border-line bg-canvas px-3 py-2" />
        </label>
        {error && <p role="alert" className="text-sm text-status-failed">{error}</p>}
        <Button type="submit" variant="primary" disabled={busy || !password}>Sign in</Button>
      </form>
    </main>
  );
}
