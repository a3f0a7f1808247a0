import { useCallback, useEffect, useState } from 'react';
import { checkSession, type Session } from '@/features/auth/api/auth';
import { LoginPage } from '@/features/auth/components/LoginPage';
import { useSettingsStore } from '@/stores/settingsStore';
import { App } from './App';

/** The login gate: the console only mounts (and connects) once the brain lets us in. */
export function Root() {
  const [session, setSession] = useState<Session>('unknown');
  const theme = useSettingsStore((s) => s.theme);
  const check = useCallback(() => {
    checkSession().then(setSession, () => setSession('open'));
  }, []);
  useEffect(() => {
    document.documentElement.dataset.theme = theme;
  }, [theme]);
  useEffect(check, [check]);
  if (session === 'unknown') return null;
  if (session === 'signed-out') return <LoginPage onSignedIn={check} />;
  return <App />;
}
